"""Fetch TUM RGB-D sequences: stream the archive, extract it safely, verify, then publish.

The sequence folder appears in its destination only once it is complete and opens as a
TUM sequence (an interrupted or corrupt download leaves nothing behind), because it is
extracted into a temporary folder beside the destination and renamed into place.
"""

import shutil
import tarfile
import tempfile
import urllib.error
import urllib.request
from pathlib import Path

from rich.progress import BarColumn, DownloadColumn, Progress, TextColumn, TimeRemainingColumn, TransferSpeedColumn

from ..errors import InputError
from .catalog import TumSequenceInfo, tum_cache_dir, tum_sequence

TUM_MIRROR = "https://cvg.cit.tum.de/rgbd/dataset"
CHUNK_BYTES = 1 << 20


def archive_url(info: TumSequenceInfo, mirror: str = TUM_MIRROR) -> str:
    return f"{mirror.rstrip('/')}/{info.archive}"


def download_sequence(name: str, dest: Path | None = None, mirror: str = TUM_MIRROR, *,
                      progress: bool = True, force: bool = False) -> Path:
    """Download the TUM sequence ``name`` into ``dest`` (default: the cache) and return its folder.

    An already present folder is returned as it is unless ``force``.
    """
    info = tum_sequence(name)
    if info is None:
        raise InputError(f"{name}: unknown TUM sequence; run `viewslam sequences` for the list")
    dest = Path(dest) if dest is not None else tum_cache_dir()
    dest.mkdir(parents=True, exist_ok=True)
    target = dest / info.name
    if target.is_dir() and not force:
        return target
    url = archive_url(info, mirror)
    with tempfile.TemporaryDirectory(dir=dest, prefix=f".{info.name}.") as scratch:
        archive = Path(scratch) / f"{info.name}.tgz"
        _fetch(url, archive, progress)
        folder = _extract(archive, Path(scratch) / "extracted", url)
        _verify(folder, url)
        if target.exists():
            shutil.rmtree(target)
        folder.rename(target)
    return target


def _fetch(url: str, path: Path, progress: bool) -> None:
    """Stream ``url`` into ``path`` with a progress bar; HTTP and network errors become InputError."""
    try:
        with urllib.request.urlopen(url, timeout=60) as response, open(path, "wb") as out:
            total = int(response.headers.get("Content-Length") or 0) or None
            columns = (TextColumn("{task.description}"), BarColumn(), DownloadColumn(), TransferSpeedColumn(),
                       TimeRemainingColumn())
            with Progress(*columns, disable=not progress, transient=True) as bar:
                task = bar.add_task(Path(url).name, total=total)
                while chunk := response.read(CHUNK_BYTES):
                    out.write(chunk)
                    bar.advance(task, len(chunk))
    except urllib.error.HTTPError as error:
        raise InputError(f"{url}: download failed: HTTP {error.code} {error.reason}") from None
    except (urllib.error.URLError, OSError) as error:
        reason = getattr(error, "reason", error)
        raise InputError(f"{url}: download failed: {reason}") from None


def _extract(archive: Path, into: Path, url: str) -> Path:
    """Extract with tarfile's ``data`` filter (no absolute paths, no escaping links or ``..``).

    Returns the sequence folder: the archive's single top-level folder, or ``into`` itself
    when the files sit at the top level.
    """
    try:
        with tarfile.open(archive, "r:gz") as tar:
            tar.extractall(into, filter="data")
    except tarfile.FilterError as error:
        raise InputError(f"{url}: unsafe archive member: {error}") from None
    except (tarfile.TarError, EOFError, OSError) as error:
        raise InputError(f"{url}: not a readable .tgz archive: {' '.join(str(error).split())}") from None
    entries = list(into.iterdir())
    if len(entries) == 1 and entries[0].is_dir():
        return entries[0]
    return into


def _verify(folder: Path, url: str) -> None:
    from .tum import open_sequence

    try:
        open_sequence(folder)
    except InputError as error:
        raise InputError(f"{url}: archive is not a TUM sequence ({error})") from None
