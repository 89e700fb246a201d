"""Where generated data (synthetic sequences, downloads, benchmark results) is cached."""

import os
from pathlib import Path


def cache_dir(*parts: str) -> Path:
    """``$VIEWSLAM_CACHE`` or ``~/.cache/viewslam``, joined with ``parts`` and created."""
    root = Path(os.environ.get("VIEWSLAM_CACHE") or Path.home() / ".cache" / "viewslam")
    path = root.joinpath(*parts)
    path.mkdir(parents=True, exist_ok=True)
    return path
