"""Rendering in worker processes: the files are those of an in-process run."""

import os

import pytest

from viewer_slam.dataset.synth import generate_scenario, read_info
from viewer_slam.dataset.synth.generate import _worker_count
from viewer_slam.errors import InputError


def files(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_two_workers_write_the_same_bytes_as_one_including_covered_frames(tmp_path):
    alone = generate_scenario("360_kidnap", tmp_path / "one", frames=20, resolution=(96, 72), seed=5, workers=1)
    pooled = generate_scenario("360_kidnap", tmp_path / "two", frames=20, resolution=(96, 72), seed=5, workers=2)
    assert len(read_info(alone)["covered_intervals"]) == 2
    written = files(alone)
    assert len(written) == 2 * 20 + 5
    assert files(pooled) == written


def test_short_runs_stay_in_process_and_workers_are_capped_by_frames():
    assert _worker_count(None, 40, (320, 240)) == 1
    assert _worker_count(None, 300, (640, 480)) == min(os.cpu_count() or 1, 300)
    assert _worker_count(8, 3, (640, 480)) == 3
    assert _worker_count(2, 300, (64, 48)) == 2


def test_fewer_than_one_worker_is_refused(tmp_path):
    with pytest.raises(InputError, match="workers must be at least 1"):
        generate_scenario("sitting_static", tmp_path / "run", frames=4, resolution=(64, 48), workers=0)
    assert not (tmp_path / "run").exists()
