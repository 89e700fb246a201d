"""The whole suite runs against a temporary viewslam cache, never the user's own.

One cache serves the session and all its xdist workers (it sits in the folder that holds
every worker's temporary directory), so a synthetic scenario is rendered once per session:
a file lock per scenario makes the other workers wait for that render instead of repeating
it. Tests that need a cache of their own still set ``VIEWSLAM_CACHE`` themselves.
"""

import functools
import os
from pathlib import Path

import pytest
from filelock import FileLock

import viewer_slam.dataset.synth as synth


@pytest.fixture(scope="session", autouse=True)
def session_cache(tmp_path_factory) -> Path:
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    cache = shared / "viewslam-cache"
    cache.mkdir(exist_ok=True)
    previous = os.environ.get("VIEWSLAM_CACHE")
    os.environ["VIEWSLAM_CACHE"] = str(cache)
    yield cache
    if previous is None:
        os.environ.pop("VIEWSLAM_CACHE", None)
    else:
        os.environ["VIEWSLAM_CACHE"] = previous


def _rendered_once(cached_scenario):
    @functools.wraps(cached_scenario)
    def locked(name, *, frames=None, resolution=(640, 480), seed=0, **options):
        from viewer_slam.cache import cache_dir

        lock = cache_dir("locks") / f"{name}-{frames}-{resolution[0]}x{resolution[1]}-s{seed}.lock"
        with FileLock(lock):
            return cached_scenario(name, frames=frames, resolution=resolution, seed=seed, **options)

    return locked


# Before the test modules import it by name.
synth.cached_scenario = _rendered_once(synth.cached_scenario)
