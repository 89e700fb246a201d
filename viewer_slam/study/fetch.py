"""Fetch the study's files from the author's repository (or a mirror) into the cache, checked by SHA-256.

Each file is fetched with ``download``'s resumable transfer into ``<cache>/.NAME.part`` and
renamed into place only once its hash is the manifest's, so the cache never holds a file
that is not the study's; a cached file is checked again before every use.
"""

import hashlib
import os
import urllib.parse
from pathlib import Path

from ..cache import cache_dir
from ..dataset.download import fetch_file
from ..errors import InputError
from .manifest import BASE_URL, COMMIT, SHA256

RETRY = "run the same `viewslam study` again"
MIRROR_HINT = "--mirror, VIEWSLAM_STUDY_MIRROR"


def default_mirror() -> str:
    """``$VIEWSLAM_STUDY_MIRROR``, else the author's repository at the pinned commit."""
    return os.environ.get("VIEWSLAM_STUDY_MIRROR") or BASE_URL


def check_mirror(mirror: str | None) -> str:
    """The base URL to fetch from; InputError naming the option if it is no URL."""
    base = mirror or default_mirror()
    parts = urllib.parse.urlsplit(base)
    if parts.scheme not in ("http", "https", "file") or (parts.scheme != "file" and not parts.netloc):
        source = "--mirror" if mirror else "VIEWSLAM_STUDY_MIRROR"
        raise InputError(f"{source} {base!r}: not a URL; expected http://HOST/PATH, https://... or file:///PATH")
    return base.rstrip("/")


def study_cache() -> Path:
    """Where the study's files are kept, one folder per pinned commit."""
    return cache_dir("study", COMMIT)


def sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        while chunk := stream.read(1 << 16):
            digest.update(chunk)
    return digest.hexdigest()


def fetch(relative: str, mirror: str, cache: Path, progress: bool = False) -> tuple[Path, bool]:
    """The cached copy of the study file ``relative`` (fetched from ``mirror`` if needed) and whether
    its hash was checked (False: the manifest has none for it).

    A cached file whose hash is wrong is fetched again; a fetched one whose hash is wrong is
    removed and is one InputError naming the URL.
    """
    target = cache / relative
    expected = SHA256.get(relative)
    if target.is_file() and (expected is None or sha256(target) == expected):
        return target, expected is not None
    target.parent.mkdir(parents=True, exist_ok=True)
    part = target.with_name(f".{target.name}.part")
    url = f"{mirror}/{relative}"
    if target.is_file():
        target.unlink()
    fetch_file(url, part, progress, RETRY, MIRROR_HINT)
    if expected is not None:
        found = sha256(part)
        if found != expected:
            part.unlink(missing_ok=True)
            raise InputError(
                f"{url}: SHA-256 {found} is not the study's {expected} (the file at commit "
                f"{COMMIT[:12]}); check the mirror ({MIRROR_HINT})"
            )
    part.replace(target)
    return target, expected is not None
