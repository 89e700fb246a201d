import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from viewer_slam.geometry.align import align_umeyama
from viewer_slam.geometry.se3 import make_pose, transform_points


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), scale=st.floats(0.05, 20.0))
def test_recovers_a_known_rigid_and_similarity_transform(seed, scale):
    rng = np.random.default_rng(seed)
    source = rng.normal(scale=2.0, size=(50, 3))
    rigid = make_pose(Rotation.from_rotvec(rng.normal(size=3)).as_matrix(), rng.normal(scale=5.0, size=3))
    np.testing.assert_allclose(align_umeyama(source, transform_points(rigid, source)), rigid, atol=1e-10)

    similarity = rigid.copy()
    similarity[:3, :3] *= scale
    target = transform_points(similarity, source)
    np.testing.assert_allclose(align_umeyama(source, target, with_scale=True), similarity, atol=1e-9 * scale)


def test_the_least_squares_fit_of_noisy_points_beats_nearby_transforms():
    rng = np.random.default_rng(1)
    source = rng.normal(size=(200, 3))
    target = transform_points(
        make_pose(Rotation.from_rotvec([0.3, -0.2, 1.0]).as_matrix(), [1, 2, 3]), source
    ) + rng.normal(scale=0.05, size=(200, 3))
    best = align_umeyama(source, target)

    def cost(transform):
        return np.sum((transform_points(transform, source) - target) ** 2)

    for _ in range(20):
        nudged = (
            make_pose(Rotation.from_rotvec(rng.normal(scale=1e-3, size=3)).as_matrix(), rng.normal(scale=1e-3, size=3))
            @ best
        )
        assert cost(nudged) > cost(best)


def test_stays_a_rotation_when_a_reflection_fits_better():
    """Mirror-image points: the unconstrained optimum is a reflection, the answer must not be."""
    source = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])
    target = source * [1, 1, -1]
    rotation = align_umeyama(source, target)[:3, :3]
    assert np.linalg.det(rotation) == pytest.approx(1.0)
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)


def test_rejects_mismatched_or_empty_point_sets():
    with pytest.raises(ValueError):
        align_umeyama(np.zeros((4, 3)), np.zeros((5, 3)))
    with pytest.raises(ValueError):
        align_umeyama(np.zeros((0, 3)), np.zeros((0, 3)))
