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
from viewer_slam.recording.viewer import viewer_binary

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


def test_view_opens_the_recording_in_the_bundled_viewer(recording, monkeypatch):
    monkeypatch.setenv("DISPLAY", ":99")
    commands = []
    monkeypatch.setattr(subprocess, "call", lambda command: commands.append(command) or 0)
    assert main(["view", str(recording)]) == 0
    assert commands == [[str(viewer_binary()), str(recording)]]
    version = subprocess.run([viewer_binary(), "--version"], capture_output=True, text=True)
    assert version.returncode == 0 and "0.41" in version.stdout


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
    process = subprocess.Popen([VIEWSLAM, "view", str(recording), "--web"], stdout=subprocess.PIPE, text=True,
                               env=environment, start_new_session=True)
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
