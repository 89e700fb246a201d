"""Coverage, lost intervals and the penalised ATE; RPE pairing and degenerate inputs."""

import numpy as np
import pytest
from fixtures_eval import TRAJECTORIES, perturbed, random_walk

from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.coverage import FILE_SPAN_RULE, coverage, file_span, lost_gap_threshold
from viewer_slam.evaluation.rpe import pairs_by_seconds
from viewer_slam.geometry.interpolation import interpolate_poses
from viewer_slam.geometry.trajectory import Trajectory, read_tum

GROUNDTRUTH = random_walk(1001, seed=3, rate_hz=100.0)  # 10 s at 100 Hz


def estimate_at(stamps: np.ndarray, seed: int = 4) -> Trajectory:
    """A 30 Hz-style estimate: groundtruth interpolated at ``stamps``, then disturbed."""
    poses, covered = interpolate_poses(GROUNDTRUTH, stamps)
    assert covered.all()
    return perturbed(Trajectory(stamps, poses), seed)


def test_an_estimate_that_stops_halfway_covers_half():
    start = GROUNDTRUTH.timestamps[0]
    halfway = estimate_at(start + np.arange(0, 5.0, 0.03))
    evaluation = evaluate(GROUNDTRUTH, halfway)
    assert evaluation.coverage.ratio == pytest.approx(0.5, abs=0.01)
    assert len(evaluation.coverage.lost_intervals) == 1
    lost_start, lost_end = evaluation.coverage.lost_intervals[0]
    assert lost_start == halfway.timestamps[-1] and lost_end == GROUNDTRUTH.timestamps[-1]
    assert evaluation.penalized_ate.stats()["rmse"] >= evaluation.ate.stats()["rmse"]
    assert evaluation.penalized_ate.stats()["n"] == pytest.approx(2 * evaluation.ate.stats()["n"], abs=2)


def test_a_full_estimate_has_full_coverage_and_penalised_equals_classic():
    start = GROUNDTRUTH.timestamps[0]
    evaluation = evaluate(GROUNDTRUTH, estimate_at(start + np.arange(0, 10.0, 0.03)))
    assert evaluation.coverage.ratio == pytest.approx(1.0, abs=0.01)
    assert evaluation.coverage.lost_intervals == []
    np.testing.assert_array_equal(evaluation.penalized_ate.errors, evaluation.ate.errors)


def test_a_gap_in_the_middle_is_one_lost_interval_charged_with_the_held_pose():
    start = GROUNDTRUTH.timestamps[0]
    stamps = start + np.arange(0, 10.0, 0.03)
    kept = (stamps < start + 3.0) | (stamps > start + 7.0)
    evaluation = evaluate(GROUNDTRUTH, estimate_at(stamps[kept]))
    last_before, first_after = stamps[stamps < start + 3.0][-1], stamps[stamps > start + 7.0][0]
    assert evaluation.coverage.lost_intervals == [(last_before, first_after)]
    assert evaluation.coverage.ratio == pytest.approx(0.6, abs=0.01)
    # The random walk moves on during the gap, so holding the last pose costs error.
    assert evaluation.penalized_ate.stats()["max"] > 10 * evaluation.ate.stats()["max"]


def test_coverage_counts_gaps_longer_than_the_threshold_only():
    stamps = np.array([0.0, 0.1, 0.2, 0.3, 0.7, 0.8, 0.9, 1.0])
    assert lost_gap_threshold(stamps) == pytest.approx(0.3)
    result = coverage((0.0, 1.0), stamps)
    assert result.lost_intervals == [(0.3, 0.7)]
    assert result.ratio == pytest.approx(0.6)
    assert coverage((0.0, 1.0), np.array([5.0])).ratio == 0.0


def test_an_empty_estimate_has_zero_coverage_and_null_error_blocks():
    evaluation = evaluate(GROUNDTRUTH, Trajectory.empty())
    blocks = evaluation.to_dict()
    start, end = GROUNDTRUTH.timestamps[0], GROUNDTRUTH.timestamps[-1]
    assert blocks["coverage"] == {
        "ratio": 0.0,
        "lost_intervals": [[start, end]],
        "span": {"start": start, "end": end, "rule": "groundtruth"},
    }
    assert blocks["ate"] is None and blocks["penalized_ate"] is None
    assert blocks["rpe"]["trans"] is None and blocks["rpe"]["rot"] is None


def test_rpe_in_seconds_pairs_each_pose_with_the_first_at_or_after_t_plus_delta():
    stamps = np.array([0.0, 0.3, 0.6, 1.0, 1.2, 1.7])
    first, second = pairs_by_seconds(stamps, 1.0)
    assert list(zip(first.tolist(), second.tolist())) == [(0, 3), (1, 5), (2, 5)]


def test_all_deltas_is_a_fixed_size_seeded_sample():
    estimate = estimate_at(GROUNDTRUTH.timestamps[0] + np.arange(0, 10.0, 0.03))
    first = evaluate(GROUNDTRUTH, estimate, all_deltas=True, seed=7)
    again = evaluate(GROUNDTRUTH, estimate, all_deltas=True, seed=7)
    other = evaluate(GROUNDTRUTH, estimate, all_deltas=True, seed=8)
    assert first.rpe_trans.stats()["n"] == 10_000
    np.testing.assert_array_equal(first.rpe_trans.errors, again.rpe_trans.errors)
    assert not np.array_equal(first.rpe_trans.errors, other.rpe_trans.errors)
    assert first.to_dict()["rpe"]["delta"] is None and first.to_dict()["rpe"]["delta_unit"] == "all"
    # Longer distances drift more: the all-distance average exceeds the one-frame RPE.
    one_frame = evaluate(GROUNDTRUTH, estimate, delta=1, delta_unit="frames")
    assert first.rpe_trans.stats()["rmse"] > one_frame.rpe_trans.stats()["rmse"]


def test_time_offset_is_applied_to_the_estimate():
    start = GROUNDTRUTH.timestamps[0]
    estimate = estimate_at(start + np.arange(0, 10.0, 0.03))
    late = Trajectory(estimate.timestamps - 50.0, estimate.poses)
    assert evaluate(GROUNDTRUTH, late).ate is None
    shifted = evaluate(GROUNDTRUTH, late, offset=50.0)
    assert shifted.ate.stats() == pytest.approx(evaluate(GROUNDTRUTH, estimate).ate.stats())
    assert shifted.coverage.ratio == pytest.approx(1.0, abs=0.01)


def test_sparse_poses_are_lost_time_at_the_sequence_frame_rate():
    # Two poses over 40 frames of a 30 Hz sequence: by their own spacing they look covered,
    # at the sequence's frame period nearly everything between them is lost.
    groundtruth = random_walk(40, seed=5)
    sparse = groundtruth.subset(np.array([0, 39]))
    span = (groundtruth.timestamps[0], groundtruth.timestamps[-1])
    assert evaluate(groundtruth, sparse, span=span).coverage.ratio == 1.0
    at_frame_rate = evaluate(groundtruth, sparse, span=span, frame_period=1 / 30)
    assert at_frame_rate.coverage.ratio == 0.0
    assert at_frame_rate.coverage.lost_intervals == [(span[0], span[1])]
    assert at_frame_rate.penalized_ate.stats()["n"] > 30


README_GROUNDTRUTH = TRAJECTORIES / "freiburg1_xyz-groundtruth.txt"
README_ESTIMATE = TRAJECTORIES / "freiburg1_xyz-rgbdslam.txt"


def test_motion_capture_before_the_camera_is_no_loss():
    """The README example: the groundtruth starts 3.5 s before the camera; the method never lost tracking."""
    groundtruth, estimate = read_tum(README_GROUNDTRUTH), read_tum(README_ESTIMATE)
    assert estimate.timestamps[0] - groundtruth.timestamps[0] > 3.4
    evaluation = evaluate(groundtruth, estimate)
    assert evaluation.coverage.ratio >= 0.99
    assert evaluation.coverage.lost_intervals == []
    assert evaluation.coverage.span == (estimate.timestamps[0], groundtruth.timestamps[-1], FILE_SPAN_RULE)
    np.testing.assert_array_equal(evaluation.penalized_ate.errors, evaluation.ate.errors)


def test_the_same_estimate_cut_at_its_middle_covers_half():
    groundtruth, estimate = read_tum(README_GROUNDTRUTH), read_tum(README_ESTIMATE)
    middle = (estimate.timestamps[0] + estimate.timestamps[-1]) / 2
    evaluation = evaluate(groundtruth, estimate.subset(estimate.timestamps <= middle))
    assert 0.45 <= evaluation.coverage.ratio <= 0.55
    assert len(evaluation.coverage.lost_intervals) == 1
    assert evaluation.coverage.lost_intervals[0][1] == groundtruth.timestamps[-1]  # the quit is not hidden


def test_the_file_span_starts_at_the_later_first_stamp_and_ends_with_the_groundtruth():
    stamps = np.arange(10.0, 20.0, 0.1)
    assert file_span(stamps, np.arange(12.0, 15.0, 0.1)) == (12.0, stamps[-1], FILE_SPAN_RULE)
    assert file_span(stamps, np.arange(5.0, 25.0, 0.1)) == (10.0, stamps[-1], FILE_SPAN_RULE)
    assert file_span(stamps, np.arange(30.0, 31.0, 0.1))[:2] == (stamps[-1], stamps[-1])
    assert file_span(stamps, np.zeros(0)) == (10.0, stamps[-1], "groundtruth")


def test_a_late_start_inside_a_given_span_is_a_loss():
    start = GROUNDTRUTH.timestamps[0]
    late = estimate_at(start + np.arange(2.0, 10.0, 0.03))
    assert evaluate(GROUNDTRUTH, late).coverage.ratio == pytest.approx(1.0, abs=0.01)
    given = evaluate(GROUNDTRUTH, late, span=(start, GROUNDTRUTH.timestamps[-1]))
    assert given.coverage.ratio == pytest.approx(0.8, abs=0.01)
    assert given.coverage.lost_intervals == [(start, late.timestamps[0])]
    assert given.coverage.span.rule == "given"
