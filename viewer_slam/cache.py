"""Where generated data (synthetic sequences, downloads, benchmark results) is cached."""

import os
from pathlib import Path


def cache_dir(*parts: str) -> Path:
    """``$VIEWSLAM_CACHE`` or ``$XDG_CACHE_HOME/viewslam`` (``~/.cache/viewslam``), joined
    with ``parts`` and created."""
    xdg = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    root = Path(os.environ.get("VIEWSLAM_CACHE") or xdg / "viewslam")
    path = root.joinpath(*parts)
    path.mkdir(parents=True, exist_ok=True)
    return path
