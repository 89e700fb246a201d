"""Properties of the metrics that hold for any trajectory (hypothesis)."""

import numpy as np
import pytest
from fixtures_eval import random_walk
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.se3 import make_pose, rotation_angle
from viewer_slam.geometry.trajectory import Trajectory

rotation_vectors = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).map(np.array)
translations = st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3).map(np.array)
seeds = st.integers(0, 10_000)


def rigid(rotation_vector, translation) -> np.ndarray:
    return make_pose(Rotation.from_rotvec(rotation_vector).as_matrix(), translation)


@settings(max_examples=40, deadline=None)
@given(seed=seeds, rotation_vector=rotation_vectors, translation=translations, scale=st.floats(0.1, 10.0))
def test_an_estimate_in_another_frame_has_zero_ate(seed, rotation_vector, translation, scale):
    groundtruth = random_walk(60, seed)
    motion = rigid(rotation_vector, translation)
    moved = Trajectory(groundtruth.timestamps, motion @ groundtruth.poses)
    assert evaluate(groundtruth, moved).ate.stats()["max"] < 1e-9

    scaled = moved.poses.copy()
    scaled[:, :3, 3] *= scale
    similar = evaluate(
        groundtruth, Trajectory(groundtruth.timestamps, scaled), scale=True, delta=1, delta_unit="frames"
    )
    assert similar.ate.stats()["max"] < 1e-9
    assert similar.rpe_trans.stats()["max"] < 1e-9  # RPE sees the estimate at the fitted scale


@settings(max_examples=30, deadline=None)
@given(
    quarter_turns=st.integers(2, 30),
    radius=st.floats(0.5, 5.0),
    offset=st.floats(0.001, 0.3),
    rotation_vector=rotation_vectors,
    translation=translations,
)
def test_a_constant_offset_no_alignment_can_absorb_gives_that_error(
    quarter_turns, radius, offset, rotation_vector, translation
):
    """A circle whose estimate sits ``offset`` above and below it, alternately, has ATE = offset.

    Alternating signs on evenly spaced points leave the centroid and the best rotation
    unchanged, so after alignment every pose is off by exactly ``offset``.
    """
    count = 4 * quarter_turns
    angle = 2 * np.pi * np.arange(count) / count
    circle = np.stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros(count)], axis=1)
    lifted = circle + np.outer(np.where(np.arange(count) % 2 == 0, offset, -offset), [0, 0, 1])
    world = rigid(rotation_vector, translation)
    stamps = np.arange(count) / 30.0
    groundtruth = Trajectory(stamps, world @ make_pose(np.broadcast_to(np.eye(3), (count, 3, 3)), circle))
    estimate = Trajectory(stamps, make_pose(np.broadcast_to(np.eye(3), (count, 3, 3)), lifted))
    np.testing.assert_allclose(evaluate(groundtruth, estimate).ate.errors, offset, rtol=1e-7)


@settings(max_examples=30, deadline=None)
@given(
    seed=seeds,
    drift_rotation=st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3).map(np.array),
    drift_translation=st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3).map(np.array),
)
def test_a_constant_error_per_frame_is_the_rpe(seed, drift_rotation, drift_translation):
    """P_{i+1} = P_i (Q_i^-1 Q_{i+1}) D gives E_i = D for every consecutive pair."""
    groundtruth = random_walk(50, seed)
    drift = rigid(drift_rotation, drift_translation)
    poses = [groundtruth.poses[0]]
    for before, after in zip(groundtruth.poses[:-1], groundtruth.poses[1:]):
        poses.append(poses[-1] @ np.linalg.inv(before) @ after @ drift)
    evaluation = evaluate(
        groundtruth, Trajectory(groundtruth.timestamps, np.array(poses)), delta=1, delta_unit="frames"
    )
    np.testing.assert_allclose(evaluation.rpe_trans.errors, np.linalg.norm(drift_translation), rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(
        evaluation.rpe_rot.errors, np.degrees(rotation_angle(drift[:3, :3])), rtol=1e-6, atol=1e-9
    )


@settings(max_examples=30, deadline=None)
@given(
    seed=seeds,
    rotation_vector=rotation_vectors,
    translation=translations,
    delta=st.sampled_from([(1, "frames"), (4, "frames"), (0.5, "seconds")]),
)
def test_rpe_is_invariant_to_a_global_rigid_motion(seed, rotation_vector, translation, delta):
    groundtruth = random_walk(60, seed)
    estimate = random_walk(60, seed + 1)
    moved = Trajectory(estimate.timestamps, rigid(rotation_vector, translation) @ estimate.poses)
    before = evaluate(groundtruth, estimate, delta=delta[0], delta_unit=delta[1])
    after = evaluate(groundtruth, moved, delta=delta[0], delta_unit=delta[1])
    np.testing.assert_allclose(after.rpe_trans.errors, before.rpe_trans.errors, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(after.rpe_rot.errors, before.rpe_rot.errors, rtol=1e-9, atol=1e-9)
    assert after.ate.stats()["rmse"] == pytest.approx(before.ate.stats()["rmse"], rel=1e-9)
