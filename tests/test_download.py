"""`viewslam download` against a local HTTP server serving archives built in the test."""

import functools
import http.server
import io
import tarfile
import threading

import pytest

from benchmark_fake_pipeline import write_tum_folder
from viewer_slam.cli import main
from viewer_slam.dataset.catalog import resolve_sequence
from viewer_slam.dataset.tum import open_sequence

NAME = "rgbd_dataset_freiburg1_xyz"


@pytest.fixture
def mirror(tmp_path):
    """A quiet HTTP server on 127.0.0.1 serving ``tmp_path / "mirror"``; yields (folder, base URL)."""
    root = tmp_path / "mirror"
    (root / "freiburg1").mkdir(parents=True)

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(root)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield root, f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def archive_of(folder, target):
    with tarfile.open(target, "w:gz") as tar:
        tar.add(folder, arcname=NAME)


def download(dest, url, name="fr1/xyz"):
    return main(["download", name, "--dest", str(dest), "--mirror", url, "--quiet"])


def test_download_extracts_verifies_and_publishes(mirror, tmp_path, capsys):
    root, url = mirror
    source = write_tum_folder(tmp_path / "source", frames=6)
    archive_of(source, root / "freiburg1" / f"{NAME}.tgz")
    dest = tmp_path / "dest"
    assert download(dest, url) == 0
    folder = dest / NAME
    assert capsys.readouterr().out == f"fr1/xyz: {folder}\n"
    assert sorted(p.relative_to(folder) for p in folder.rglob("*")) == \
           sorted(p.relative_to(source) for p in source.rglob("*"))
    assert (folder / "groundtruth.txt").read_bytes() == (source / "groundtruth.txt").read_bytes()
    assert len(open_sequence(folder)) == 6
    assert [p.name for p in dest.iterdir()] == [NAME]  # no scratch left behind


def test_downloaded_sequence_resolves_by_name(mirror, tmp_path, monkeypatch):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    root, url = mirror
    archive_of(write_tum_folder(tmp_path / "source", frames=4), root / "freiburg1" / f"{NAME}.tgz")
    assert main(["download", NAME, "--mirror", url, "--quiet"]) == 0
    expected = tmp_path / "cache" / "tum" / NAME
    assert resolve_sequence("fr1/xyz") == expected and resolve_sequence(NAME) == expected


def _served(root, payload: bytes):
    (root / "freiburg1" / f"{NAME}.tgz").write_bytes(payload)


def _tgz(members: dict[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return buffer.getvalue()


@pytest.mark.parametrize("payload, message", [
    (None, "download failed: HTTP 404"),
    (b"this is not gzip", "not a readable .tgz archive"),
    (_tgz({f"{NAME}/../../escaped.txt": b"x"}), "unsafe archive member"),
    (_tgz({f"{NAME}/README": b"no listings here"}), "archive is not a TUM sequence"),
])
def test_bad_downloads_exit_2_and_leave_nothing(mirror, tmp_path, capsys, payload, message):
    root, url = mirror
    if payload is not None:
        _served(root, payload)
    dest = tmp_path / "dest"
    assert download(dest, url) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith(f"viewslam: error: {url}/freiburg1/{NAME}.tgz: ")
    assert message in error
    assert list(dest.iterdir()) == [] and not (tmp_path / "escaped.txt").exists()


def test_unknown_name_and_refused_connection_are_input_errors(tmp_path, capsys):
    assert main(["download", "fr9/nothing", "--dest", str(tmp_path), "--quiet"]) == 2
    assert "fr9/nothing: unknown TUM sequence" in capsys.readouterr().err
    assert download(tmp_path, "http://127.0.0.1:9") == 2  # the discard port: nothing listens
    assert "download failed" in capsys.readouterr().err
