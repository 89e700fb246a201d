"""The gap rule: a node or keyframe trajectory is sparse, not lost; it is lost where the camera went on without it."""

import numpy as np
import pytest
from fixtures_eval import SHARED_DATA, TRAJECTORIES, random_walk

from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.coverage import coverage, is_sparse, lost_gap_threshold
from viewer_slam.geometry.trajectory import Trajectory, read_tum

STUDY = SHARED_DATA / "study_kasar2018"
GROUNDTRUTH = random_walk(30 * 40, seed=11)  # 40 s at 30 Hz, moving all the time (~1 cm, ~1 degree a frame)


def nodes(groundtruth: Trajectory, every: int = 30, skip: slice | None = None) -> Trajectory:
    """One pose a second (every 30th frame), as RTAB-Map exports its graph's nodes; ``skip`` drops some."""
    index = np.arange(0, len(groundtruth), every)
    if skip is not None:
        index = np.delete(index, np.arange(len(index))[skip])
    return groundtruth.subset(index)


def test_one_node_a_second_is_sparse_and_not_lost_even_at_the_frame_rate():
    sparse = nodes(GROUNDTRUTH)
    span = (GROUNDTRUTH.timestamps[0], GROUNDTRUTH.timestamps[-1])
    assert is_sparse(sparse.timestamps, 1 / 30) and not is_sparse(GROUNDTRUTH.timestamps, 1 / 30)
    assert lost_gap_threshold(sparse.timestamps, 1 / 30) == pytest.approx(3.0)
    for frame_period in (None, 1 / 30):
        evaluation = evaluate(GROUNDTRUTH, sparse, span=span, frame_period=frame_period)
        assert evaluation.coverage.lost_intervals == [] and evaluation.coverage.ratio == 1.0
        assert evaluation.penalized_ate.stats()["rmse"] == evaluation.ate.stats()["rmse"]


def test_nodes_that_stop_while_the_camera_moves_on_are_lost():
    sparse = nodes(GROUNDTRUTH, skip=slice(15, 25))  # no node from 15 s to 25 s
    evaluation = evaluate(
        GROUNDTRUTH, sparse, frame_period=1 / 30, span=(GROUNDTRUTH.timestamps[0], GROUNDTRUTH.timestamps[-1])
    )
    assert len(evaluation.coverage.lost_intervals) == 1
    start, end = evaluation.coverage.lost_intervals[0]
    assert (start - GROUNDTRUTH.timestamps[0], end - GROUNDTRUTH.timestamps[0]) == pytest.approx((14.0, 25.0))
    assert evaluation.coverage.ratio == pytest.approx(1 - 11 / (40 - 1 / 30))


def test_no_node_while_the_camera_rests_is_not_lost():
    """The same ten-second gap, but the camera stands still during it: a node system adds no node then."""
    poses = GROUNDTRUTH.poses.copy()
    rest = slice(14 * 30, 25 * 30)
    poses[rest] = poses[14 * 30]
    poses[25 * 30 :] = poses[14 * 30] @ np.linalg.inv(GROUNDTRUTH.poses[25 * 30]) @ GROUNDTRUTH.poses[25 * 30 :]
    resting = Trajectory(GROUNDTRUTH.timestamps, poses)
    sparse = nodes(resting, skip=slice(15, 25))
    covered = coverage((resting.timestamps[0], resting.timestamps[-1]), sparse.timestamps, 1 / 30, resting)
    assert covered.lost_intervals == []
    without_groundtruth = coverage((resting.timestamps[0], resting.timestamps[-1]), sparse.timestamps, 1 / 30)
    assert len(without_groundtruth.lost_intervals) == 1  # the timing alone cannot tell


def test_a_per_frame_trajectory_keeps_the_frame_rate_rule():
    dense = GROUNDTRUTH.subset(np.r_[0:300, 310 : len(GROUNDTRUTH)])  # 10 frames (0.33 s) missing
    evaluation = evaluate(GROUNDTRUTH, dense, frame_period=1 / 30)
    assert len(evaluation.coverage.lost_intervals) == 1


def test_the_study_rtabmap_kidnap_run_is_lost_after_the_kidnap_only():
    """RTAB-Map's 1 Hz nodes on fr2/360_kidnap: one lost interval, from its last node (14.2 s) to the end."""
    base = STUDY / "freiburg2_360_kidnap" / "rtab"
    groundtruth, estimate = read_tum(base / "groundtruth.txt"), read_tum(base / "rtabmap_poses.txt")
    span = (groundtruth.timestamps[0], groundtruth.timestamps[-1])
    for frame_period in (None, 1 / 30):  # a bare file, or with the sequence's frame rate
        covered = evaluate(groundtruth, estimate, span=span, frame_period=frame_period).coverage
        assert covered.lost_intervals == [(estimate.timestamps[-1], groundtruth.timestamps[-1])]
    assert evaluate(groundtruth, estimate).coverage.ratio == pytest.approx(0.299, abs=0.001)


def test_a_keyframe_trajectory_is_not_lost_between_keyframes():
    """ORB-SLAM's monocular keyframes on fr2/desk (spacing 0.04 to 3.4 s as it culls keyframes)."""
    evaluation = evaluate(
        read_tum(TRAJECTORIES / "fr2_desk_groundtruth.txt"),
        read_tum(TRAJECTORIES / "fr2_desk_ORB_kf_mono.txt"),
        align="sim3",
    )
    assert evaluation.coverage.lost_intervals == [] and evaluation.coverage.ratio == 1.0
