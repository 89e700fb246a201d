"""`viewslam download` against a local HTTP server serving archives built in the test."""

import http.server
import io
import random
import re
import socket
import tarfile
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from bag_writer import write_tum_bag
from benchmark_fake_pipeline import write_tum_folder
from fixtures_eval import TUM_RPY, tum_excerpt

from viewer_slam.cli import main
from viewer_slam.dataset.catalog import resolve_sequence
from viewer_slam.dataset.sources import open_source

NAME = "rgbd_dataset_freiburg1_xyz"


class RangeHandler(http.server.BaseHTTPRequestHandler):
    """GET of a file below ``server.root``, honouring ``Range: bytes=N-`` (206, or 416 past the end).

    The server records each request's Range header and the body bytes it sent; with
    ``server.cut_after`` set it sends only that many body bytes of the next response and
    drops the connection, as a failing network would.
    """

    def do_GET(self):
        server = self.server
        server.ranges.append(self.headers.get("Range"))
        path = server.root / self.path.lstrip("/")
        if not path.is_file():
            self.send_error(404)
            return
        data = path.read_bytes()
        match = re.fullmatch(r"bytes=(\d+)-", self.headers.get("Range") or "")
        start = int(match.group(1)) if match and server.honour_range else 0
        if start >= len(data) > 0:
            self.send_response(416)
            self.send_header("Content-Range", f"bytes */{len(data)}")
            self.send_header("Content-Length", "0")
            self.end_headers()
            return
        self.send_response(206 if start else 200)
        if start:
            self.send_header("Content-Range", f"bytes {start}-{len(data) - 1}/{len(data)}")
        self.send_header("Content-Length", str(len(data) - start))
        self.end_headers()
        body = data[start:]
        if server.cut_after is not None:
            body, server.cut_after = body[: server.cut_after], None
        self.wfile.write(body)
        server.sent += len(body)

    def log_message(self, *args):
        pass


@pytest.fixture(autouse=True)
def environment(monkeypatch, tmp_path):
    """A private cache, and none of the developer's own download settings."""
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("VIEWSLAM_DATA", raising=False)
    monkeypatch.delenv("VIEWSLAM_TUM_MIRROR", raising=False)


@pytest.fixture
def mirror(tmp_path):
    """A TUM mirror on 127.0.0.1 serving ``tmp_path / "mirror"`` (``.root``) at ``.url``."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), RangeHandler)
    server.root = tmp_path / "mirror"
    (server.root / "freiburg1").mkdir(parents=True)
    server.url = f"http://127.0.0.1:{server.server_address[1]}"
    server.ranges, server.sent, server.cut_after, server.honour_range = [], 0, None, True
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


def serve(server, payload: bytes, name: str = NAME, suffix: str = ".tgz") -> bytes:
    camera = name.split("_")[2]
    (server.root / camera).mkdir(exist_ok=True)
    (server.root / camera / f"{name}{suffix}").write_bytes(payload)
    return payload


def archive_of(folder: Path, name: str = NAME) -> bytes:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        tar.add(folder, arcname=name)
    return buffer.getvalue()


def download(dest, url, name="fr1/xyz"):
    return main(["download", name, "--dest", str(dest), "--mirror", url, "--quiet"])


def same_files(folder: Path, source: Path) -> bool:
    return sorted(p.relative_to(folder) for p in folder.rglob("*")) == sorted(
        p.relative_to(source) for p in source.rglob("*")
    ) and all(p.read_bytes() == (folder / p.relative_to(source)).read_bytes() for p in source.rglob("*") if p.is_file())


def test_download_extracts_verifies_and_publishes_then_is_not_repeated(mirror, tmp_path, capsys):
    source = write_tum_folder(tmp_path / "source", frames=6)
    serve(mirror, archive_of(source))
    dest = tmp_path / "dest"
    assert download(dest, mirror.url) == 0
    folder = dest / NAME
    assert capsys.readouterr().out == f"fr1/xyz: {folder}\n"
    assert same_files(folder, source) and len(open_source(folder)) == 6
    assert [p.name for p in dest.iterdir()] == [NAME]  # no scratch folder and no .part left behind
    assert download(dest, mirror.url) == 0
    assert capsys.readouterr().out == f"fr1/xyz: {folder}\n" and mirror.ranges == [None]


def test_downloaded_sequence_resolves_by_name(mirror, tmp_path):
    serve(mirror, archive_of(write_tum_folder(tmp_path / "source", frames=4)))
    assert main(["download", NAME, "--mirror", mirror.url, "--quiet"]) == 0
    expected = tmp_path / "cache" / "tum" / NAME
    assert resolve_sequence("fr1/xyz") == expected and resolve_sequence(NAME) == expected


def test_viewslam_data_replaces_the_cache_for_downloads_and_names(mirror, tmp_path, monkeypatch):
    monkeypatch.setenv("VIEWSLAM_DATA", str(tmp_path / "data"))
    serve(mirror, archive_of(write_tum_folder(tmp_path / "source", frames=4)))
    assert main(["download", "fr1/xyz", "--mirror", mirror.url, "--quiet"]) == 0
    assert (tmp_path / "data" / NAME).is_dir() and not (tmp_path / "cache" / "tum" / NAME).exists()
    assert resolve_sequence("fr1/xyz") == tmp_path / "data" / NAME


def test_viewslam_tum_mirror_replaces_the_base_url_and_mirror_beats_it(mirror, tmp_path, monkeypatch, capsys):
    serve(mirror, archive_of(write_tum_folder(tmp_path / "source", frames=4)))
    monkeypatch.setenv("VIEWSLAM_TUM_MIRROR", f"{mirror.url}/nowhere")
    assert download(tmp_path / "dest", mirror.url) == 0
    monkeypatch.setenv("VIEWSLAM_TUM_MIRROR", f"{mirror.url}/")
    assert main(["download", "fr1/xyz", "--dest", str(tmp_path / "other"), "--quiet"]) == 0
    assert (tmp_path / "other" / NAME).is_dir() and mirror.ranges == [None, None]


def test_interrupted_download_resumes_where_it_stopped(mirror, tmp_path, capsys):
    source = write_tum_folder(tmp_path / "source", frames=6)
    archive = serve(mirror, archive_of(source))
    cut = len(archive) // 3
    mirror.cut_after = cut
    part = tmp_path / "cache" / "tum" / f".{NAME}.tgz.part"
    assert main(["download", "fr1/xyz", "--mirror", mirror.url, "--quiet"]) == 2
    error = capsys.readouterr().err
    assert (
        error.count("\n") == 1
        and f"download failed: connection closed after {cut:,} of {len(archive):,} bytes" in error
        and f"run the same `viewslam download` again to resume from the {cut:,} bytes in {part}" in error
    )
    assert part.read_bytes() == archive[:cut] and not (part.parent / NAME).exists()
    assert main(["sequences"]) == 0
    assert ["fr1/xyz", "testing", "groundtruth", "partial"] in [
        line.split() for line in capsys.readouterr().out.splitlines()
    ]

    assert main(["download", "fr1/xyz", "--mirror", mirror.url, "--quiet"]) == 0
    assert mirror.ranges == [None, f"bytes={cut}-"]
    assert mirror.sent == len(archive) < 2 * len(archive)
    assert same_files(part.parent / NAME, source) and not part.exists()


@pytest.mark.parametrize(
    "kept, honour_range, whole_archive_sent",
    [
        pytest.param(lambda archive: archive, True, False, id="part-already-complete"),
        pytest.param(lambda archive: archive + b"stale", True, True, id="part-longer-than-archive"),
        pytest.param(lambda archive: archive[:100], False, True, id="server-ignores-range"),
    ],
)
def test_part_that_cannot_be_resumed_is_used_or_restarted(mirror, tmp_path, kept, honour_range, whole_archive_sent):
    source = write_tum_folder(tmp_path / "source", frames=6)
    archive = serve(mirror, archive_of(source))
    dest = tmp_path / "dest"
    dest.mkdir()
    (dest / f".{NAME}.tgz.part").write_bytes(kept(archive))
    mirror.honour_range = honour_range
    assert download(dest, mirror.url) == 0
    assert mirror.ranges[0] == f"bytes={len(kept(archive))}-"
    assert mirror.sent == (len(archive) if whole_archive_sent else 0)
    assert same_files(dest / NAME, source) and [p.name for p in dest.iterdir()] == [NAME]


def member(name: str, data: bytes = b"x", kind: bytes = tarfile.REGTYPE, link: str = "") -> tuple:
    info = tarfile.TarInfo(name)
    info.type, info.linkname, info.size = kind, link, len(data) if kind == tarfile.REGTYPE else 0
    return info, io.BytesIO(data) if kind == tarfile.REGTYPE else None


def tgz(*members: tuple) -> bytes:
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as tar:
        for info, data in members:
            tar.addfile(info, data)
    return buffer.getvalue()


# Random bytes do not compress, so cutting the archive short cuts the compressed stream.
INTACT = tgz(member(f"{NAME}/rgb.txt", random.Random(0).randbytes(50_000)))
WRONG_CRC = INTACT[:-8] + bytes(byte ^ 0xFF for byte in INTACT[-8:-4]) + INTACT[-4:]


@pytest.mark.parametrize(
    "payload, message",
    [
        pytest.param(None, "download failed: HTTP 404 Not Found; check the mirror", id="missing"),
        pytest.param(b"this is not gzip", "truncated or corrupt archive (Not a gzipped file", id="not-gzip"),
        pytest.param(INTACT[: len(INTACT) // 2], "truncated or corrupt archive", id="truncated"),
        pytest.param(WRONG_CRC, "truncated or corrupt archive (CRC check failed", id="corrupt"),
        pytest.param(tgz(member(f"{NAME}/../../escaped.txt")), "unsafe archive member", id="dot-dot"),
        pytest.param(tgz(member("/tmp/viewslam-absolute.txt")), "unsafe archive member", id="absolute"),
        pytest.param(
            tgz(member(f"{NAME}/rgb.txt", kind=tarfile.SYMTYPE, link="../../escaped.txt")),
            "unsafe archive member",
            id="link-outside",
        ),
        pytest.param(tgz(member(f"{NAME}/tty", kind=tarfile.CHRTYPE)), "unsafe archive member", id="device"),
        pytest.param(tgz(member(f"{NAME}/README", b"no listings here")), "archive is not a TUM sequence", id="not-tum"),
    ],
)
def test_bad_downloads_exit_2_and_leave_nothing(mirror, tmp_path, capsys, payload, message):
    if payload is not None:
        serve(mirror, payload)
    dest = tmp_path / "dest"
    assert download(dest, mirror.url) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith(f"viewslam: error: {mirror.url}/freiburg1/{NAME}.tgz: ")
    assert message in error and "Traceback" not in error
    assert list(dest.iterdir()) == []  # neither a folder nor a .part to resume: a retry starts afresh
    assert not (tmp_path / "escaped.txt").exists() and not Path("/tmp/viewslam-absolute.txt").exists()


@pytest.mark.parametrize(
    "damage, message",
    [
        pytest.param(lambda image: image.unlink(), "image listed in the sequence is missing", id="image-missing"),
        pytest.param(lambda image: image.write_bytes(image.read_bytes()[:-20]), "truncated PNG", id="image-truncated"),
        pytest.param(
            lambda image: image.write_bytes(image.read_bytes()[:40] + b"\0" * 8 + image.read_bytes()[48:]),
            "corrupt PNG (bad checksum",
            id="image-corrupt",
        ),
    ],
)
def test_an_archive_whose_images_are_missing_or_damaged_is_refused(mirror, tmp_path, capsys, damage, message):
    source = write_tum_folder(tmp_path / "source", frames=4)
    damage(sorted((source / "depth").iterdir())[2])
    serve(mirror, archive_of(source))
    dest = tmp_path / "dest"
    assert download(dest, mirror.url) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "archive is not a TUM sequence (<archive>/" in error and message in error
    assert list(dest.iterdir()) == []


def test_unknown_name_suggests_close_names_before_downloading_anything(mirror, tmp_path, capsys):
    assert main(["download", "fr1/xyz", "fr2/360_kidnapp", "--dest", str(tmp_path), "--mirror", mirror.url]) == 2
    error = capsys.readouterr().err
    assert (
        error == "viewslam: error: fr2/360_kidnapp: unknown TUM sequence; did you mean fr2/360_kidnap? "
        "`viewslam sequences` lists them all\n"
    )
    assert main(["download", "fr9/nothing", "--dest", str(tmp_path)]) == 2
    assert (
        capsys.readouterr().err
        == "viewslam: error: fr9/nothing: unknown TUM sequence; `viewslam sequences` lists them all\n"
    )
    assert mirror.ranges == [] and list(tmp_path.glob("*xyz*")) == []


def test_network_failure_says_what_to_retry(tmp_path, capsys):
    with socket.socket() as probe:  # a port that was free a moment ago: nothing listens on it
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    url = f"http://127.0.0.1:{port}"
    assert download(tmp_path, url) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith(
        f"viewslam: error: {url}/freiburg1/{NAME}.tgz: download failed: "
    )
    assert error.rstrip().endswith("; run the same `viewslam download` again")
    assert list(tmp_path.iterdir()) == []


def test_a_host_that_does_not_exist_says_to_check_the_mirror_not_to_retry(tmp_path, capsys):
    url = "http://viewslam-no-such-host.invalid"
    assert download(tmp_path, url) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "the host 'viewslam-no-such-host.invalid' is not known" in error
    assert "check the mirror (--mirror, VIEWSLAM_TUM_MIRROR)" in error and "again" not in error
    assert list(tmp_path.iterdir()) == []


def test_two_downloads_of_one_sequence_at_once_both_get_it_whole(mirror, tmp_path):
    from viewer_slam.dataset.download import download_sequence

    source = write_tum_folder(tmp_path / "source", frames=6)
    serve(mirror, archive_of(source))
    dest = tmp_path / "dest"
    with ThreadPoolExecutor(2) as pool:
        folders = list(pool.map(lambda _: download_sequence("fr1/xyz", dest, mirror.url, progress=False), range(2)))
    assert folders == [dest / NAME] * 2 and same_files(dest / NAME, source)
    assert [path.name for path in dest.iterdir()] == [NAME]  # no .part and no lock left
    assert mirror.ranges == [None]  # fetched once: the second waited and found it installed


def test_download_bag_fetches_the_bag_resumably_and_the_name_resolves_to_it(mirror, tmp_path, capsys):
    source = write_tum_folder(tmp_path / "source", frames=4)
    bag = serve(mirror, write_tum_bag(source, tmp_path / "source.bag").read_bytes(), suffix=".bag")
    cut = len(bag) // 2
    mirror.cut_after = cut
    tum = tmp_path / "cache" / "tum"
    assert main(["download", "fr1/xyz", "--bag", "--mirror", mirror.url, "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"viewslam: error: {mirror.url}/freiburg1/{NAME}.bag: download failed: ")
    assert f"to resume from the {cut:,} bytes in {tum / f'.{NAME}.bag.part'}" in error
    assert main(["sequences"]) == 0 and ["fr1/xyz", "testing", "groundtruth", "partial"] in [
        line.split() for line in capsys.readouterr().out.splitlines()
    ]

    assert main(["download", "fr1/xyz", "--bag", "--mirror", mirror.url, "--quiet"]) == 0
    assert capsys.readouterr().out == f"fr1/xyz: {tum / f'{NAME}.bag'}\n"
    assert mirror.ranges == [None, f"bytes={cut}-"] and mirror.sent == len(bag)
    assert (tum / f"{NAME}.bag").read_bytes() == bag and [p.name for p in tum.iterdir()] == [f"{NAME}.bag"]
    assert resolve_sequence("fr1/xyz") == tum / f"{NAME}.bag" and len(open_source(tum / f"{NAME}.bag")) == 4
    assert main(["sequences"]) == 0 and ["fr1/xyz", "testing", "groundtruth", "bag"] in [
        line.split() for line in capsys.readouterr().out.splitlines()
    ]


def test_a_downloaded_bag_that_does_not_open_is_discarded(mirror, tmp_path, capsys):
    serve(mirror, b"#ROSBAG V2.0\n but nothing after the magic", suffix=".bag")
    dest = tmp_path / "dest"
    assert main(["download", "fr1/xyz", "--bag", "--dest", str(dest), "--mirror", mirror.url, "--quiet"]) == 2
    error = capsys.readouterr().err
    assert (
        error.startswith(
            f"viewslam: error: {mirror.url}/freiburg1/{NAME}.bag: download is not a usable ROS bag (<download>: "
        )
        and error.count("\n") == 1
    )
    assert list(dest.iterdir()) == []  # nothing to resume: the retry downloads afresh


@pytest.mark.skipif(not TUM_RPY.is_dir(), reason="shared TUM excerpt not present")
def test_downloaded_sequence_can_be_recorded_by_name(mirror, tmp_path):
    name = "rgbd_dataset_freiburg1_rpy"
    serve(mirror, archive_of(tum_excerpt(tmp_path / "excerpt", frames=10), name), name)
    assert main(["download", "fr1/rpy", "--mirror", mirror.url, "--quiet"]) == 0
    out = tmp_path / "recordings" / "rpy.rrd"
    assert main(["record", "fr1/rpy", "--pipeline", "rgbdslam", "--max-frames", "8", "--out", str(out), "--quiet"]) == 0
    assert out.is_file() and out.with_suffix(".json").is_file()
