"""`viewslam view`: the native viewer, one line when there is no display, the web viewer on 127.0.0.1."""

import os
import re
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from viewer_slam.cli import main
from viewer_slam.rerun_adapter.viewer import viewer_binary

VIEWSLAM = Path(sys.executable).with_name("viewslam")


def tiny_recording(path: Path) -> Path:
    """A complete one-point Rerun recording at ``path``."""
    import rerun as rr

    stream = rr.RecordingStream("viewslam-test")
    stream.save(path)
    stream.log("point", rr.Points3D([[0.0, 0.0, 0.0]]))
    stream.flush()
    stream.disconnect()
    return path


@pytest.fixture
def recording(tmp_path) -> Path:
    return tiny_recording(tmp_path / "x.rrd")


def test_view_of_a_missing_file_is_bad_input(tmp_path, capsys):
    assert main(["view", str(tmp_path / "none.rrd")]) == 2
    assert "no such recording" in capsys.readouterr().err


def shell_viewer(folder: Path, monkeypatch, script: str) -> Path:
    """A stand-in for the bundled viewer: ``script`` (shell) run with the viewer's arguments,
    which it also writes to the returned file."""
    import viewer_slam.rerun_adapter.viewer as viewer

    called = folder / "called-with"
    binary = folder / "shell-rerun"
    binary.write_text(f'#!/bin/sh\necho "$@" > {called}\n{script}\n')
    binary.chmod(0o755)
    monkeypatch.setattr(viewer, "viewer_binary", lambda: binary)
    return called


def test_view_opens_the_recording_in_the_bundled_viewer(recording, tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("DISPLAY", ":99")
    called = shell_viewer(tmp_path, monkeypatch, "echo 'WARN re_viewer: a log line of its own' >&2; exit 0")
    assert main(["view", str(recording)]) == 0
    assert called.read_text() == f"{recording}\n"
    assert capfd.readouterr().err == ""  # the viewer's own log lines are not ours to print
    version = subprocess.run([viewer_binary(), "--version"], capture_output=True, text=True)
    assert version.returncode == 0 and "0.41" in version.stdout


def test_a_viewer_that_fails_later_is_one_line_with_its_reason(recording, tmp_path, monkeypatch, capfd):
    import viewer_slam.rerun_adapter.viewer as viewer

    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(viewer, "VIEWER_START_S", 0.0)
    shell_viewer(
        tmp_path, monkeypatch, "printf '\\033[33m WARN\\033[0m noise\\nError: wgpu: the GPU went away\\n' >&2; exit 1"
    )
    assert main(["view", str(recording)]) == 2
    assert (
        capfd.readouterr().err == f"viewslam: error: {recording}: the viewer ended with an error (wgpu: the GPU "
        f"went away)\n"
    )


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="DISPLAY and WAYLAND_DISPLAY are X11/Wayland's")
def test_with_no_display_view_says_so_in_one_line_and_names_web(recording, monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(subprocess, "call", lambda command: pytest.fail("the viewer must not start"))
    assert main(["view", str(recording)]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "no display" in error and "--web" in error


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="DISPLAY and WAYLAND_DISPLAY are X11/Wayland's")
def test_record_spawn_with_no_display_says_so_before_anything_is_written(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    out = tmp_path / "run.rrd"
    assert main(["record", str(tmp_path / "anything"), "--out", str(out), "--spawn", "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("viewslam: error: --spawn: no display") and f"viewslam view {out} --web" in error
    assert error.count("\n") == 1 and list(tmp_path.iterdir()) == []


def test_view_web_serves_the_web_viewer_on_localhost(tmp_path):
    recording = tiny_recording(tmp_path / "one-point.rrd")
    environment = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    process = subprocess.Popen(
        [VIEWSLAM, "view", str(recording), "--web"],
        stdout=subprocess.PIPE,
        text=True,
        env=environment,
        start_new_session=True,
    )
    try:
        line = process.stdout.readline()
        address = re.search(r"http://127\.0\.0\.1:\d+/\S*", line)
        assert address, line
        deadline, page = time.monotonic() + 30, None
        while page is None and time.monotonic() < deadline:
            assert process.poll() is None
            try:
                with urllib.request.urlopen(address.group(0), timeout=5) as response:
                    page = response.status, response.read()
            except OSError:
                time.sleep(0.3)
        assert page is not None and page[0] == 200 and b"<html" in page[1].lower()
    finally:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(timeout=30)


FAKE_VIEWER = """#!{python}
import socket, sys, time
from urllib.parse import urlsplit
url = sys.argv[sys.argv.index("--connect") + 1]
{body}
"""
# Connects to the server it was told to, says where, and stays up past the start check.
STAYS_UP = """address = urlsplit(url)
socket.create_connection((address.hostname, address.port), timeout=5).close()
open(sys.argv[0] + ".seen", "w").write(url)
time.sleep(1.0)"""


@pytest.fixture
def tiny_run(tmp_path, monkeypatch):
    """A four-frame folder the fake pipeline records in a moment, with a display, and earlier outputs."""
    from benchmark_fake_pipeline import MODULE, write_tum_folder

    from viewer_slam.pipelines import base

    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    monkeypatch.setenv("DISPLAY", ":99")
    out = tmp_path / "out"
    out.mkdir()
    (out / "run.rrd").write_bytes(b"earlier recording")
    return write_tum_folder(tmp_path / "tiny", frames=4), out / "run.rrd"


def fake_viewer(tmp_path: Path, monkeypatch, body: str) -> Path:
    import viewer_slam.rerun_adapter.viewer as viewer

    script = tmp_path / "rerun"
    script.write_text(FAKE_VIEWER.format(python=sys.executable, body=body))
    script.chmod(0o755)
    monkeypatch.setattr(viewer, "viewer_binary", lambda: script)
    monkeypatch.setattr(viewer, "VIEWER_START_S", 0.5)
    return script


def test_record_spawn_streams_to_the_viewer_it_started_and_to_no_other(tiny_run, tmp_path, monkeypatch):
    sequence, out = tiny_run
    script = fake_viewer(tmp_path, monkeypatch, STAYS_UP)
    assert main(["record", str(sequence), "--pipeline", "fake", "--out", str(out), "--spawn", "--quiet"]) == 0
    served = Path(f"{script}.seen").read_text()  # the viewer was a client of the run's own server
    assert re.fullmatch(r"rerun\+http://127\.0\.0\.1:(\d+)/proxy", served) and ":9876/" not in served
    assert subprocess.run([viewer_binary(), "rrd", "verify", str(out)], capture_output=True).returncode == 0


def test_record_spawn_of_a_viewer_that_exits_at_once_is_one_line_and_loses_nothing(
    tiny_run, tmp_path, monkeypatch, capsys
):
    sequence, out = tiny_run
    fake_viewer(tmp_path, monkeypatch, "sys.exit(1)")
    assert main(["record", str(sequence), "--pipeline", "fake", "--out", str(out), "--spawn", "--quiet"]) == 2
    error = capsys.readouterr().err
    assert (
        error.startswith("viewslam: error: --spawn: the viewer exited at once (exit code 1)")
        and f"viewslam view {out} --web" in error
        and error.count("\n") == 1
    )
    assert [path.name for path in out.parent.iterdir()] == ["run.rrd"] and out.read_bytes() == b"earlier recording"


def refusing_port() -> int:
    from viewer_slam.rerun_adapter.viewer import free_port

    return free_port()


@pytest.fixture
def silent_listener():
    """A port that accepts connections and never says a word: no viewer, or one that hangs."""
    import socket

    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        yield listener.getsockname()[1]


@pytest.mark.parametrize(
    "address, problem",
    [
        ("localhost", "not a viewer address"),
        ("localhost:0", "not a viewer address"),
        ("localhost:http", "not a viewer address"),
        ("http://localhost:9876/proxy", "not a viewer address"),
        ("rerun+http://localhost:9876/other", "not a viewer address"),
        ("127.0.0.1:{refusing}", "no viewer accepts connections there"),
        ("127.0.0.1:{silent}", "no answer from a viewer"),
    ],
    ids=["no-port", "port-0", "port-not-a-number", "http-scheme", "not-the-proxy", "refused", "silent"],
)
def test_record_connect_to_no_viewer_is_one_line_and_loses_nothing(
    address, problem, tiny_run, silent_listener, monkeypatch, capsys
):
    import viewer_slam.rerun_adapter.viewer as viewer

    monkeypatch.setattr(viewer, "CONNECT_TIMEOUT_S", 0.5)
    sequence, out = tiny_run
    address = address.format(refusing=refusing_port(), silent=silent_listener)
    assert (
        main(["record", str(sequence), "--pipeline", "fake", "--out", str(out), "--connect", address, "--quiet"]) == 2
    )
    error = capsys.readouterr().err
    assert error.startswith(f"viewslam: error: --connect {address}: {problem}") and error.count("\n") == 1, error
    assert [path.name for path in out.parent.iterdir()] == ["run.rrd"] and out.read_bytes() == b"earlier recording"


def test_record_connect_keeps_the_recording_when_the_viewer_goes_away(tiny_run):
    """A gRPC server that answers the greeting, then closes every connection: a viewer that died."""
    import socket
    import threading

    sequence, out = tiny_run
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen()

        def answer_then_close() -> None:
            while True:
                try:
                    connection, _ = listener.accept()
                except OSError:
                    return
                with connection:
                    connection.sendall(bytes([0, 0, 0, 4, 0, 0, 0, 0, 0]))  # an empty SETTINGS frame

        threading.Thread(target=answer_then_close, daemon=True).start()
        address = f"127.0.0.1:{listener.getsockname()[1]}"
        assert (
            main(["record", str(sequence), "--pipeline", "fake", "--out", str(out), "--connect", address, "--quiet"])
            == 0
        )
    assert subprocess.run([viewer_binary(), "rrd", "verify", str(out)], capture_output=True).returncode == 0
