"""Fixtures of the benchmark tests: the fake pipeline registered, a cache of the test's own, a tiny sequence."""

import pytest
from benchmark_fake_pipeline import MODULE, write_tum_folder

from viewer_slam.pipelines import base


@pytest.fixture
def fake_pipeline(monkeypatch, tmp_path):
    """The fake pipeline selectable as ``fake``, and the cache in the test's own folder."""
    monkeypatch.setitem(base.PIPELINE_MODULES, "fake", MODULE)
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))


@pytest.fixture
def folder(tmp_path):
    """A valid 30-frame TUM folder."""
    return write_tum_folder(tmp_path / "tiny", frames=30)
