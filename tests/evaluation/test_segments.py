"""Segment-aligned ATE and the choice of alignment: errors at the frames that made them."""

import numpy as np
import pytest
from fixtures_eval import perturbed, random_walk
from scipy.spatial.transform import Rotation

from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.alignment import MIN_SEGMENT_PAIRS
from viewer_slam.evaluation.coverage import tracked_segments
from viewer_slam.geometry.se3 import invert, make_pose, transform_points
from viewer_slam.geometry.trajectory import Trajectory

GROUNDTRUTH = random_walk(300, seed=11)  # 10 s at 30 Hz
NOISE_M = 0.002
OFFSET = make_pose(
    Rotation.from_rotvec(np.array([0.2, -0.4, 0.9])).as_matrix(), np.array([0.8, -0.5, 0.3])
)  # a second map's frame


def split_estimate(gap: slice, moved: slice, seed: int = 1) -> Trajectory:
    """The groundtruth, disturbed by ``NOISE_M``; frames ``gap`` missing, frames ``moved`` in another frame."""
    poses = perturbed(GROUNDTRUTH, seed, sigma_m=NOISE_M, sigma_rad=0.001).poses.copy()
    poses[moved] = OFFSET @ poses[moved]
    kept = np.ones(len(GROUNDTRUTH), dtype=bool)
    kept[gap] = False
    return Trajectory(GROUNDTRUTH.timestamps[kept], poses[kept])


def test_a_rigid_offset_between_two_segments_vanishes_when_each_is_aligned_on_its_own():
    estimate = split_estimate(gap=slice(140, 160), moved=slice(160, None))
    evaluation = evaluate(GROUNDTRUTH, estimate)
    assert len(evaluation.coverage.lost_intervals) == 1
    assert evaluation.segment_ate.stats()["max"] < 5 * NOISE_M
    assert evaluation.ate.stats()["rmse"] > 0.1  # one fit cannot lay both segments onto the groundtruth
    np.testing.assert_array_equal(evaluation.segment_ate.timestamps, evaluation.ate.timestamps)


def test_after_a_kidnap_the_frames_before_the_loss_get_their_own_small_error():
    # A short first segment, then a long one in another frame: the global fit follows the
    # long one and blames the frames before the loss; aligned per segment they are small.
    estimate = split_estimate(gap=slice(60, 75), moved=slice(75, None))
    evaluation = evaluate(GROUNDTRUTH, estimate)
    before = evaluation.ate.timestamps < GROUNDTRUTH.timestamps[60]
    assert before.sum() == 60
    assert evaluation.segment_ate.errors[before].max() < 5 * NOISE_M
    assert evaluation.ate.errors[before].min() > 20 * NOISE_M
    # The long segment dominates the global fit, so it is nearly as good either way.
    assert evaluation.ate.errors[~before].mean() < evaluation.ate.errors[before].mean() / 3


def test_without_a_loss_the_segment_aligned_ate_is_the_ate():
    evaluation = evaluate(GROUNDTRUTH, perturbed(GROUNDTRUTH, 2))
    assert evaluation.coverage.lost_intervals == []
    np.testing.assert_array_equal(evaluation.segment_ate.errors, evaluation.ate.errors)


def test_a_segment_too_short_to_align_takes_the_previous_segments_transform():
    # Segments: frames 0-99 (exact, own frame A), 110-111 (two poses, frame B), 125-299 (frame B).
    frame_a = make_pose(Rotation.from_rotvec(np.array([0.0, 0.0, 0.5])).as_matrix(), np.array([1.0, 0.0, 0.0]))
    poses = GROUNDTRUTH.poses.copy()
    poses[:100] = frame_a @ poses[:100]
    poses[100:] = OFFSET @ poses[100:]
    kept = np.r_[0:100, 110:112, 125:300]
    evaluation = evaluate(GROUNDTRUTH, Trajectory(GROUNDTRUTH.timestamps[kept], poses[kept]))
    assert tracked_segments(GROUNDTRUTH.timestamps[kept]).tolist() == [0] * 100 + [1] * 2 + [2] * 175
    short = np.isin(evaluation.segment_ate.timestamps, GROUNDTRUTH.timestamps[110:112])
    assert short.sum() == 2 < MIN_SEGMENT_PAIRS
    # Laid with segment 0's transform (frame A undone), the two poses sit where OFFSET put them.
    expected = np.linalg.norm(
        transform_points(invert(frame_a) @ OFFSET, GROUNDTRUTH.positions[110:112]) - GROUNDTRUTH.positions[110:112],
        axis=1,
    )
    np.testing.assert_allclose(evaluation.segment_ate.errors[short], expected, rtol=1e-9)
    assert evaluation.segment_ate.errors[~short].max() < 1e-9


def test_a_short_first_segment_takes_the_next_fitted_segments_transform():
    poses = GROUNDTRUTH.poses.copy()
    poses[2:] = OFFSET @ poses[2:]  # the two first poses stay in the groundtruth frame
    kept = np.r_[0:2, 20:300]
    evaluation = evaluate(GROUNDTRUTH, Trajectory(GROUNDTRUTH.timestamps[kept], poses[kept]))
    expected = np.linalg.norm(
        transform_points(invert(OFFSET), GROUNDTRUTH.positions[:2]) - GROUNDTRUTH.positions[:2], axis=1
    )
    np.testing.assert_allclose(evaluation.segment_ate.errors[:2], expected, rtol=1e-9)
    assert evaluation.segment_ate.errors[2:].max() < 1e-9


def test_align_segments_scores_ate_and_the_penalty_per_segment():
    estimate = split_estimate(gap=slice(140, 160), moved=slice(160, None))
    rigid, segments = evaluate(GROUNDTRUTH, estimate), evaluate(GROUNDTRUTH, estimate, align="segments")
    assert segments.to_dict()["alignment"] == "segments" and segments.alignment is None
    np.testing.assert_array_equal(segments.ate.errors, rigid.segment_ate.errors)
    assert segments.penalized_ate.stats()["rmse"] < rigid.penalized_ate.stats()["rmse"]
    np.testing.assert_allclose(
        segments.aligned_positions(estimate), GROUNDTRUTH.positions[np.r_[0:140, 160:300]], atol=5 * NOISE_M
    )


def test_origin_alignment_lays_the_first_poses_onto_each_other():
    estimate = Trajectory(GROUNDTRUTH.timestamps, OFFSET @ GROUNDTRUTH.poses)
    origin = evaluate(GROUNDTRUTH, estimate, align="origin")
    assert origin.to_dict()["alignment"] == "origin"
    np.testing.assert_allclose(origin.alignment, invert(OFFSET), atol=1e-12)
    assert origin.ate.stats()["max"] < 1e-9
    unaligned = evaluate(GROUNDTRUTH, estimate, align="none")
    np.testing.assert_allclose(
        unaligned.ate.errors, np.linalg.norm(estimate.positions - GROUNDTRUTH.positions, axis=1), rtol=1e-12
    )
    # RPE never depends on the alignment.
    np.testing.assert_array_equal(origin.rpe_trans.errors, unaligned.rpe_trans.errors)


def test_scale_is_the_sim3_alignment():
    scaled = GROUNDTRUTH.poses.copy()
    scaled[:, :3, 3] *= 0.4
    estimate = Trajectory(GROUNDTRUTH.timestamps, scaled)
    sim3, spelled = evaluate(GROUNDTRUTH, estimate, align="sim3"), evaluate(GROUNDTRUTH, estimate, scale=True)
    assert sim3.to_dict() == spelled.to_dict()
    assert sim3.to_dict()["alignment"] == "sim3" and sim3.segment_ate.stats()["max"] < 1e-9


@pytest.mark.parametrize("options", [{"align": "affine"}, {"align": "origin", "scale": True}])
def test_unknown_or_contradictory_alignments_are_refused(options):
    with pytest.raises(ValueError, match="align"):
        evaluate(GROUNDTRUTH, GROUNDTRUTH, **options)
