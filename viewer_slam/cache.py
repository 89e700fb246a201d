"""Where generated data (synthetic sequences, downloads, benchmark results) is cached, and
what it holds: a rendered scenario takes about a megabyte a frame, so the cache must be
visible (``viewslam sequences``) and clearable without hunting for the folder."""

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from .errors import InputError

# Folders whose every child is an entry of its own (a scenario run, a downloaded sequence);
# any other folder of the cache is one entry.
LISTED_BY_CHILD = ("synth", "tum")
KEPT_ON_CLEAR = ("tum",)  # downloads take hours to fetch again; renders and results are regenerated


def cache_root() -> Path:
    """``$VIEWSLAM_CACHE`` or ``$XDG_CACHE_HOME/viewslam`` (``~/.cache/viewslam``), not created."""
    xdg = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return Path(os.environ.get("VIEWSLAM_CACHE") or xdg / "viewslam")


def cache_dir(*parts: str) -> Path:
    """:func:`cache_root` joined with ``parts`` and created; InputError naming the variable if
    that is impossible."""
    root = cache_root()
    path = root.joinpath(*parts)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        source = "VIEWSLAM_CACHE" if os.environ.get("VIEWSLAM_CACHE") else "the cache folder"
        raise InputError(f"{source} {root}: cannot create {path}: {error.strerror or error}") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{path}: the cache folder is not writable (set VIEWSLAM_CACHE to a writable folder)")
    return path


@dataclass(frozen=True)
class CacheEntry:
    """One thing the cache holds: its path relative to the root, and its size in bytes."""

    name: str
    path: Path
    size: int


def cache_entries(root: Path | None = None) -> list[CacheEntry]:
    """Every entry of the cache, by name (a cache that does not exist holds none)."""
    root = cache_root() if root is None else root
    entries = []
    for folder in sorted(root.iterdir()) if root.is_dir() else ():
        children = sorted(folder.iterdir()) if folder.name in LISTED_BY_CHILD and folder.is_dir() else [folder]
        entries += [CacheEntry(str(child.relative_to(root)), child, _size(child)) for child in children]
    return entries


def clear_cache(root: Path | None = None) -> list[CacheEntry]:
    """Remove every entry but the downloads (:data:`KEPT_ON_CLEAR`) and the work in progress;
    the entries removed. A name starting with a dot is a render, a download or a write being
    staged by a process still running, which renames it into place or removes it: removing it
    under that process would make it fail, so it stays."""
    removed = [
        entry
        for entry in cache_entries(root)
        if entry.name.split("/")[0] not in KEPT_ON_CLEAR and not entry.path.name.startswith(".")
    ]
    for entry in removed:
        try:
            if entry.path.is_dir() and not entry.path.is_symlink():
                shutil.rmtree(entry.path)
            else:
                entry.path.unlink()
        except FileNotFoundError:
            continue  # removed meanwhile by another process
        except OSError as error:
            raise InputError(f"{entry.path}: cannot remove it from the cache: {error.strerror or error}") from None
    return removed


def _size(path: Path) -> int:
    """Bytes of the files under ``path`` (links not followed)."""
    if not path.is_dir() or path.is_symlink():
        return path.lstat().st_size
    return sum((Path(folder) / name).lstat().st_size for folder, _, names in os.walk(path) for name in names)
