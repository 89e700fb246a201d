"""Where generated data (synthetic sequences, downloads, benchmark results) is cached."""

import os
from pathlib import Path

from .errors import InputError


def cache_dir(*parts: str) -> Path:
    """``$VIEWSLAM_CACHE`` or ``$XDG_CACHE_HOME/viewslam`` (``~/.cache/viewslam``), joined
    with ``parts`` and created; InputError naming the variable if that is impossible."""
    xdg = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    root = Path(os.environ.get("VIEWSLAM_CACHE") or xdg / "viewslam")
    path = root.joinpath(*parts)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        source = "VIEWSLAM_CACHE" if os.environ.get("VIEWSLAM_CACHE") else "the cache folder"
        raise InputError(f"{source} {root}: cannot create {path}: {error.strerror or error}") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{path}: the cache folder is not writable (set VIEWSLAM_CACHE to a writable folder)")
    return path
