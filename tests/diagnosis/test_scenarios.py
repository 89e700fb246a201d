"""The diagnosis on the study's failures: synthetic 360_kidnap and texture-less plane, blanked real frames.

Every run is short (320x240 synthetic, the first 45 frames of the real excerpt); the causes
come from the signals the runs measure, with the default thresholds.
"""

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth.generate import cached_scenario
from viewer_slam.diagnosis import SignalRecorder, diagnose_losses
from viewer_slam.geometry.trajectory import Trajectory, write_tum
from viewer_slam.pipelines.base import pipeline_class
from viewer_slam.pipelines.params import apply_overrides
from viewer_slam.pipelines.run import run_pipeline
from viewer_slam.runs.replay import estimate_replay
from viewer_slam.runs.service import score_run

pytestmark = pytest.mark.slow
REAL = Path("/work/shared/data/tum/rgbd_dataset_freiburg1_rpy")
FAST = {"Rtabmap/DetectionRate": 5}
BLANKED = range(20, 30)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("VIEWSLAM_CACHE", str(tmp_path_factory.mktemp("cache")))
        yield


def diagnosed(sequence, pipeline: str, max_frames: int | None = None, **overrides) -> list[dict]:
    recorder = SignalRecorder()
    params = apply_overrides(pipeline_class(pipeline).Params(), overrides, "test")
    run = run_pipeline(
        sequence, pipeline, params, max_frames=max_frames, sinks=[recorder], frame_sinks=[recorder.frame]
    )
    return diagnose_losses(pipeline, run.tracking_lost, recorder.signals(), run.tracking_minimum, sequence.groundtruth)


def synthetic(name: str, frames: int):
    folder = cached_scenario(name, frames=frames, resolution=(320, 240), seed=0)
    return open_source(folder), json.loads((folder / "scenario.json").read_text())


def test_each_covering_of_360_kidnap_is_a_blocked_sensor(cache):
    sequence, info = synthetic("360_kidnap", 120)
    losses = diagnosed(sequence, "rtabmap", **FAST, **{"Odom/ResetCountdown": 5})
    covered = info["covered_intervals"]
    assert len(losses) == len(covered) == 2
    for loss, (start, end) in zip(losses, covered):
        assert start <= loss["timestamp"] <= end
        assert loss["cause"] == "sensor blocked"
        assert loss["evidence"]["uniform_share"] == 1.0 and loss["evidence"]["valid_depth_share"] == 0.0


def test_the_texture_less_plane_has_too_few_features(cache):
    sequence, _ = synthetic("nostructure_notexture_near_withloop", 60)
    losses = diagnosed(sequence, "rtabmap", **FAST)
    assert losses and losses[0]["cause"] == "too few features"
    evidence = losses[0]["evidence"]
    assert evidence["corners"] < evidence["minimum"] <= evidence["keypoints"]  # detector found only noise
    assert evidence["valid_depth_share"] > 0.9 and "sensor blocked" not in losses[0]["causes"]


def blank(tmp_path: Path, colour: bool, depth: bool):
    """A copy of the real excerpt with frames 20..29 black and/or without depth."""
    copy = tmp_path / REAL.name
    shutil.copytree(REAL, copy)
    stamps = open_source(copy).timestamps
    first, last = stamps[BLANKED[0]] - 0.01, stamps[BLANKED[-1]] + 0.01
    for listing, wanted in (("rgb.txt", colour), ("depth.txt", depth)):
        for line in (copy / listing).read_text().splitlines():
            if wanted and not line.startswith("#") and first <= float(line.split()[0]) <= last:
                path = copy / line.split()[1]
                cv2.imwrite(str(path), np.zeros_like(cv2.imread(str(path), cv2.IMREAD_UNCHANGED)))
    return open_source(copy)


def test_real_frames_blanked_in_colour_and_depth_are_a_blocked_sensor(tmp_path):
    sequence = blank(tmp_path, colour=True, depth=True)
    losses = diagnosed(sequence, "rtabmap", max_frames=45)
    assert [loss["frame"] for loss in losses] == [BLANKED[0]]
    assert losses[0]["cause"] == "sensor blocked"
    since_start = sequence.timestamps[BLANKED[0]] - sequence.timestamps[0]
    assert losses[0]["text"].startswith(f"rtabmap lost at {since_start:.1f} s: sensor blocked")


def test_real_frames_without_depth_have_no_depth(tmp_path):
    losses = diagnosed(blank(tmp_path, colour=False, depth=True), "rgbdslam", max_frames=45)
    assert [loss["frame"] for loss in losses] == [BLANKED[0]]
    assert losses[0]["cause"] == "no depth" and losses[0]["evidence"]["corners"] >= losses[0]["evidence"]["minimum"]


def test_an_imported_estimate_with_a_gap_over_blanked_frames_is_a_blocked_sensor(tmp_path):
    """A run is a run: a trajectory file without poses where the frames are blanked gets the same cause."""
    sequence = blank(tmp_path, colour=True, depth=True)
    kept = [i for i in range(45) if i not in BLANKED]
    poses, covered = sequence.groundtruth_at(sequence.timestamps[kept])
    estimate = tmp_path / "estimate.txt"
    write_tum(estimate, Trajectory(sequence.timestamps[kept][covered], poses[covered]))
    losses = score_run(
        sequence, estimate_replay(sequence, estimate, max_frames=45), "other", max_frames=45
    ).run.tracking_lost
    assert [loss["frame"] for loss in losses] == [BLANKED[0]]
    assert losses[0]["cause"] == "sensor blocked" and "keypoints" not in losses[0]["evidence"]
