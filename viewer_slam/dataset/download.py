"""Fetch TUM RGB-D sequences: download (resumably), check, extract safely, verify, publish.

The archive is downloaded into ``<dest>/.<name>.tgz.part``, which survives an interrupted
transfer so that the next call asks only for the missing bytes (HTTP Range). The sequence
folder appears in ``dest`` only once it is complete and opens as a TUM sequence, because
it is extracted into a temporary folder beside it and renamed into place. The ``.part``
is removed once the sequence is in place, or as soon as the archive proves unusable, so
that a retry starts from a clean download. With ``bag``, the sequence's ROS bag is fetched
the same way into ``<dest>/.<name>.bag.part`` and published as ``<dest>/<name>.bag`` once it
opens as a sequence.
"""

import gzip
import http.client
import os
import re
import shutil
import socket
import tarfile
import tempfile
import urllib.error
import urllib.parse
import urllib.request
import zlib
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from rich.progress import BarColumn, DownloadColumn, TextColumn, TimeRemainingColumn, TransferSpeedColumn

from ..atomic import check_writable, exclusive, writing
from ..errors import InputError
from ..progress import StderrProgress
from ..stopping import at_safe_points
from .catalog import TumSequenceInfo, known_tum_sequence, tum_cache_dir

TUM_MIRROR = "https://cvg.cit.tum.de/rgbd/dataset"
CHUNK_BYTES = 1 << 16
TIMEOUT_S = 60
RETRY = "run the same `viewslam download` again"


class BadArchive(InputError):
    """The downloaded archive is unusable (corrupt, unsafe, not a sequence): its ``.part`` is
    discarded, so that a retry downloads it afresh instead of resuming a bad file."""


@dataclass
class _Transfer:
    """An open response delivering the archive from byte ``start`` of ``total`` (None: unknown)."""

    response: http.client.HTTPResponse
    start: int
    total: int | None


def default_mirror() -> str:
    """``$VIEWSLAM_TUM_MIRROR`` (a local copy of TUM's server), else TUM's server."""
    return os.environ.get("VIEWSLAM_TUM_MIRROR") or TUM_MIRROR


def archive_url(info: TumSequenceInfo, mirror: str | None = None, bag: bool = False) -> str:
    """The archive's (with ``bag``, the bag's) URL below ``mirror`` (default: :func:`default_mirror`);
    InputError if that is no URL."""
    base = mirror or default_mirror()
    try:
        parts = urllib.parse.urlsplit(base)
        parts.port  # noqa: B018  (a port that is no number raises here)
    except ValueError:  # e.g. an IPv6 address without its closing bracket
        parts = None
    if parts is None or parts.scheme not in ("http", "https", "file") or (parts.scheme != "file" and not parts.netloc):
        source = "--mirror" if mirror else "VIEWSLAM_TUM_MIRROR"
        raise InputError(f"{source} {base!r}: not a URL; expected http://HOST/PATH, https://... or file:///PATH")
    return f"{base.rstrip('/')}/{info.bag if bag else info.archive}"


def partial_archive(dest: Path, name: str, bag: bool = False) -> Path:
    """Where the archive (or bag) of the sequence officially called ``name`` accumulates in
    ``dest`` until it is installed."""
    return Path(dest) / f".{name}.{'bag' if bag else 'tgz'}.part"


def download_sequence(
    name: str,
    dest: Path | None = None,
    mirror: str | None = None,
    *,
    progress: bool = True,
    force: bool = False,
    bag: bool = False,
) -> Path:
    """Download the TUM sequence ``name`` into ``dest`` (default: the TUM folder) and return its
    folder, or with ``bag`` its ROS bag ``<dest>/<name>.bag``.

    An already present folder (bag) is returned as it is unless ``force``; ``mirror``
    defaults to :func:`default_mirror`.
    """
    info = known_tum_sequence(name)
    url = archive_url(info, mirror, bag)
    dest = Path(dest) if dest is not None else tum_cache_dir()
    if dest.exists() and not dest.is_dir():
        raise InputError.at(dest, "is a file; --dest takes a folder")
    target = dest / (f"{info.name}.bag" if bag else info.name)
    if (target.is_file() if bag else target.is_dir()) and not force:
        return target
    part = partial_archive(dest, info.name, bag)
    check_writable(part)
    with exclusive([part], wait=True):  # a second download of the same sequence waits for the first
        if (target.is_file() if bag else target.is_dir()) and not force:
            return target
        _fetch(url, part, progress)
        try:
            (_install_bag if bag else _install)(part, target, url)
        except BadArchive:
            part.unlink(missing_ok=True)
            raise
        part.unlink(missing_ok=True)
    return target


def fetch_file(
    url: str, part: Path, progress: bool, retry: str = RETRY, mirror_hint: str = "--mirror, VIEWSLAM_TUM_MIRROR"
) -> None:
    """Complete ``part`` from ``url`` (resuming what it holds); a failure is one InputError that says
    ``retry`` (how to resume) or, for a client error, to check ``mirror_hint``."""
    _fetch(url, part, progress, retry, mirror_hint)


def _fetch(
    url: str, part: Path, progress: bool, retry: str = RETRY, mirror_hint: str = "--mirror, VIEWSLAM_TUM_MIRROR"
) -> None:
    """Complete ``part`` from ``url``; transfer failures keep what arrived and say how to resume."""
    try:
        transfer = _open_from(url, part.stat().st_size if part.exists() else 0)
        if transfer is not None:
            with transfer.response:
                _receive(transfer, part, progress)
    except urllib.error.HTTPError as error:
        advice = f"check the mirror ({mirror_hint})" if error.code < 500 else f"{retry} later"
        raise InputError(f"{url}: download failed: HTTP {error.code} {error.reason}; {advice}") from None
    except (urllib.error.URLError, http.client.HTTPException, OSError) as error:
        reason = " ".join(str(getattr(error, "reason", error)).split()) or type(error).__name__
        if isinstance(getattr(error, "reason", None), socket.gaierror):  # no such host: waiting will not help
            host = urllib.parse.urlsplit(url).hostname
            raise InputError(
                f"{url}: download failed: the host {host!r} is not known ({reason}); check the "
                f"mirror ({mirror_hint}) and the network"
            ) from None
        kept = part.stat().st_size if part.exists() else 0
        resume = f" to resume from the {kept:,} bytes in {part}" if kept else ""
        raise InputError(f"{url}: download failed: {reason}; {retry}{resume}") from None


def _open_from(url: str, offset: int) -> _Transfer | None:
    """Request the archive from byte ``offset`` on; None when ``offset`` bytes are already all of it.

    A server that ignores Range answers 200 with the whole file (start 0); one that finds
    ``offset`` past the end answers 416, and a ``.part`` longer than the archive is stale,
    so the download starts over.
    """
    headers = {"Range": f"bytes={offset}-"} if offset else {}
    try:
        response = urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=TIMEOUT_S)
    except urllib.error.HTTPError as error:
        if error.code != 416 or not offset:
            raise
        if _content_range(error.headers.get("Content-Range"))[1] == offset:
            return None
        return _open_from(url, 0)
    if offset and response.status == 206:
        start, total = _content_range(response.headers.get("Content-Range"))
        if start == offset:
            return _Transfer(response, start, total)
        response.close()
        return _open_from(url, 0)
    length = response.headers.get("Content-Length")
    return _Transfer(response, 0, int(length) if length and length.isdigit() else None)


def _content_range(header: str | None) -> tuple[int | None, int | None]:
    """``(first byte, total size)`` of ``bytes 100-199/1000`` or ``bytes */1000``; None where absent."""
    match = re.fullmatch(r"bytes (?:(\d+)-\d+|\*)/(\d+|\*)", (header or "").strip())
    if match is None:
        return None, None
    first, total = match.groups()
    return (int(first) if first else None), (int(total) if total != "*" else None)


def _receive(transfer: _Transfer, part: Path, progress: bool) -> None:
    """Write the response's body to ``part`` (appended to its first ``start`` bytes) with a progress bar."""
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        DownloadColumn(),
        TransferSpeedColumn(),
        TimeRemainingColumn(),
    )
    received = transfer.start
    with at_safe_points() as stop, StderrProgress(*columns, enabled=progress, transient=True) as bar:
        with writing(part):
            out = open(part, "ab" if transfer.start else "wb")  # noqa: SIM115  (closed below, under the guard)
        try:
            task = bar.add_task(Path(transfer.response.url).name, total=transfer.total, completed=received)
            while chunk := transfer.response.read1(CHUNK_BYTES):  # whatever has arrived, up to CHUNK_BYTES
                with writing(part):
                    out.write(chunk)
                    out.flush()  # every byte received survives an interrupted transfer
                received += len(chunk)
                bar.update(task, completed=received)
                stop.check()  # a stop signal ends the transfer here, with every byte received kept
        finally:
            with writing(part):
                out.close()
    if transfer.total is not None and received < transfer.total:
        raise ConnectionError(f"connection closed after {received:,} of {transfer.total:,} bytes")


def _install(archive: Path, target: Path, url: str) -> None:
    """Extract ``archive`` beside ``target``, verify it, and only then move it to ``target``."""
    with tempfile.TemporaryDirectory(dir=target.parent, prefix=f".{target.name}.") as scratch:
        folder = _extract(archive, Path(scratch), url)
        _verify(folder, Path(scratch), url)
        if target.exists():
            shutil.rmtree(target)
        folder.rename(target)


def _install_bag(part: Path, target: Path, url: str) -> None:
    """Open the downloaded bag as a sequence, and only then move it to ``target``."""
    from .rosbag import open_bag

    checked = target.with_name(f".{target.name}")  # rosbags tells a ROS 1 bag by its .bag suffix
    part.replace(checked)
    try:
        open_bag(checked)
    except InputError as error:
        checked.unlink()
        problem = str(error).replace(str(checked), "<download>")
        raise BadArchive(
            f"{url}: download is not a usable ROS bag ({problem}); {RETRY} to download it afresh"
        ) from None
    checked.replace(target)


def _extract(archive: Path, into: Path, url: str) -> Path:
    """Extract a gzip-compressed tar, refusing unsafe members, and check the gzip CRC to the end.

    Returns the sequence folder: the archive's single top-level folder, or ``into`` itself
    when the files sit at the top level. Failures writing to disk are plain InputErrors (the
    archive may be fine); everything else means the archive is unusable.
    """
    try:
        with gzip.open(archive) as stream:
            with tarfile.open(fileobj=stream, mode="r:") as tar:
                tar.extractall(into, filter=_safe_member)
            while stream.read(CHUNK_BYTES):  # tar stops at its end marker; gzip checks its CRC at EOF
                pass
    except tarfile.FilterError as error:
        raise BadArchive(f"{url}: unsafe archive member: {error}") from None
    except (tarfile.TarError, gzip.BadGzipFile, EOFError, zlib.error) as error:
        detail = " ".join(str(error).split()) or type(error).__name__
        raise BadArchive(f"{url}: truncated or corrupt archive ({detail}); {RETRY} to download it afresh") from None
    except OSError as error:
        raise InputError(f"{url}: cannot extract into {into}: {error}") from None
    entries = list(into.iterdir())
    if len(entries) == 1 and entries[0].is_dir():
        return entries[0]
    return into


def _safe_member(member: tarfile.TarInfo, dest: str) -> tarfile.TarInfo:
    """tarfile's ``data`` filter (no ``..`` escapes, no links leaving ``dest``, no device files),
    except that an absolute name is refused rather than made relative: a TUM archive has none."""
    if PurePosixPath(member.name).is_absolute():
        raise tarfile.AbsolutePathError(member)
    return tarfile.data_filter(member, dest)


def _verify(folder: Path, scratch: Path, url: str) -> None:
    """Open the extracted folder as a TUM sequence; the problem names files as in the archive."""
    from .tum import open_tum

    try:
        open_tum(folder).check_images()
    except InputError as error:
        problem = str(error).replace(str(scratch), "<archive>")
        raise BadArchive(f"{url}: archive is not a TUM sequence ({problem})") from None
