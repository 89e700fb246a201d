"""v2's RANSAC against numbers worked out by hand from its formulas (node.cpp, misc.cpp)."""

import numba
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.frontend.ransac import (
    LARGE_THETA,
    LARGE_THETA_OVERFLOWS,
    jacobi_rotation,
    mahalanobis_squared,
    preferred_samples,
    ransac_rigid,
)
from viewer_slam.geometry.se3 import invert, make_pose

# errorFunction2: lateral variance (3 tan(58 deg / 640))^2 z, (3 tan(45 deg / 480))^2 z; depth (0.01 z^2)^2.
RASTER_X = (3 * np.tan(np.radians(58) / 640)) ** 2
RASTER_Y = (3 * np.tan(np.radians(45) / 480)) ** 2
IDENTITY = np.eye(4)


def distance(source, target, transform=IDENTITY, sigma_depth=0.01):
    return mahalanobis_squared(transform[None], np.array([source], float), np.array([target], float), sigma_depth)[0, 0]


def test_lateral_error_is_weighed_by_the_raster_variance_of_both_points():
    assert distance([0, 0, 1], [0.01, 0, 1]) == pytest.approx(0.01**2 / (2 * RASTER_X * 1.0))


def test_depth_error_is_weighed_by_the_kinect_depth_variance():
    # sigma_z = 0.01 z^2: 0.04 m at 2 m and 0.042025 m at 2.05 m
    assert distance([0, 0, 2], [0, 0, 2.05]) == pytest.approx(0.05**2 / (0.04**2 + 0.042025**2))


def test_source_covariance_is_turned_with_the_rotation():
    quarter_turn = make_pose(
        Rotation.from_rotvec([0, 0, np.pi / 2]).as_matrix(), [0, 0, 0]
    )  # x and y raster variances swap
    assert distance([0, 0, 1], [0.01, 0, 1], quarter_turn) == pytest.approx(0.01**2 / (RASTER_Y + RASTER_X))


def test_pairs_beyond_the_shortcut_bound_are_outliers_outright():
    # |delta|^2 = 0.0025 > 2 * (max(raster, 1e-4) + max(raster, 1e-4)) = 0.0004 at 1 m
    assert distance([0, 0, 1], [0, 0.05, 1]) == np.inf


def test_samples_prefer_the_best_matches_as_the_smaller_of_two_uniform_draws():
    rng = np.random.default_rng(0)
    drawn = np.concatenate(preferred_samples(5, 40000, rng, size=1))
    frequencies = np.bincount(drawn, minlength=5) / len(drawn)
    # P(min of two uniform draws from 5 = i) = (2 (5 - i) - 1) / 25
    np.testing.assert_allclose(frequencies, np.array([9, 7, 5, 3, 1]) / 25, atol=0.01)
    assert all(len(set(s)) == 4 for s in preferred_samples(6, 100, rng))


def scene(rng, count=300, outliers=150):
    target = rng.uniform([-1.5, -1.0, 1.0], [1.5, 1.0, 3.5], (count, 3))
    truth = make_pose(Rotation.from_rotvec([0.05, -0.1, 0.03]).as_matrix(), [0.1, -0.05, 0.08])
    source = (target - truth[:3, 3]) @ truth[:3, :3]  # truth maps source onto target
    source[:outliers] = rng.uniform([-1.5, -1.0, 1.0], [1.5, 1.0, 3.5], (outliers, 3))
    return source, target, truth


def test_ransac_finds_the_motion_among_half_outliers_and_flags_them():
    source, target, truth = scene(np.random.default_rng(1))
    result = ransac_rigid(
        source,
        target,
        iterations=200,
        max_mahalanobis=3.0,
        min_inliers=20,
        sigma_depth=0.01,
        rng=np.random.default_rng(0),
    )
    assert result is not None
    assert result.inliers[150:].all() and result.inliers[:150].sum() <= 3
    np.testing.assert_allclose(result.transform, truth, atol=1e-6)


def test_ransac_refuses_pure_noise():
    rng = np.random.default_rng(2)
    source, target = rng.uniform(0.5, 3.0, (200, 3)), rng.uniform(0.5, 3.0, (200, 3))
    assert (
        ransac_rigid(
            source,
            target,
            iterations=200,
            max_mahalanobis=3.0,
            min_inliers=20,
            sigma_depth=0.01,
            rng=np.random.default_rng(0),
        )
        is None
    )


def test_ransac_is_deterministic_for_a_seed():
    source, target, _ = scene(np.random.default_rng(3))
    first, second = (
        ransac_rigid(
            source,
            target,
            iterations=100,
            max_mahalanobis=3.0,
            min_inliers=20,
            sigma_depth=0.01,
            rng=np.random.default_rng(7),
        )
        for _ in range(2)
    )
    np.testing.assert_array_equal(first.transform, second.transform)
    np.testing.assert_array_equal(first.inliers, second.inliers)


def test_required_inliers_drop_to_three_quarters_of_few_matches():
    # 22 matches, 18 true: min_matches 20 becomes int(0.75 * 22) = 16, so 18 inliers suffice (v2).
    source, target, truth = scene(np.random.default_rng(4), count=22, outliers=4)
    result = ransac_rigid(
        source,
        target,
        iterations=200,
        max_mahalanobis=3.0,
        min_inliers=20,
        sigma_depth=0.01,
        rng=np.random.default_rng(0),
    )
    assert result is not None and result.inlier_count == 18
    assert invert(result.transform) @ truth == pytest.approx(np.eye(4), abs=1e-6)


def test_points_on_a_plane_give_the_proper_rotation_not_a_reflection():
    # 60 points on the plane z = 2 (a rank-2 cross-covariance), turned a quarter about the optical axis
    rng = np.random.default_rng(5)
    source = np.column_stack([rng.uniform(-1, 1, (60, 2)), np.full(60, 2.0)])
    truth = make_pose(Rotation.from_rotvec([0, 0, np.pi / 2]).as_matrix(), [0.05, 0.0, 0.1])
    target = source @ truth[:3, :3].T + truth[:3, 3]
    result = ransac_rigid(
        source,
        target,
        iterations=200,
        max_mahalanobis=3.0,
        min_inliers=20,
        sigma_depth=0.01,
        rng=np.random.default_rng(0),
    )
    assert result is not None and result.inliers.all()
    np.testing.assert_allclose(result.transform, truth, atol=1e-9)


@numba.njit(error_model="numpy")
def _jacobi_rotation_formula(theta):
    t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + np.sqrt(theta * theta + 1.0))
    return t, 1.0 / np.sqrt(t * t + 1.0)


def _bits(value: float) -> int:
    return int(np.float64(value).view(np.uint64))


def test_jacobi_rotation_is_the_formula_to_the_bit():
    # every binade of both signs, and each side of the bounds where the square roots are skipped
    rng = np.random.default_rng(0)
    magnitudes = np.ldexp(rng.uniform(1, 2, 40_000), rng.integers(-1074, 1024, 40_000))
    edges = [LARGE_THETA, LARGE_THETA_OVERFLOWS / 2, LARGE_THETA_OVERFLOWS, np.sqrt(np.finfo(float).max)]
    near = [np.nextafter(edge, direction) for edge in edges for direction in (0.0, np.inf)]
    special = [0.0, 5e-324, 1.0, 2.0**26, np.finfo(float).max, np.inf, np.nan]
    thetas = np.concatenate([magnitudes, edges, near, special])
    thetas = np.concatenate([thetas, -thetas])
    for theta in thetas:
        assert [_bits(v) for v in jacobi_rotation(theta)] == [_bits(v) for v in _jacobi_rotation_formula(theta)], theta


def test_jacobi_rotation_skips_the_square_roots_only_where_they_do_not_count():
    # just below 2^27, theta² + 1 still differs from theta²: the formula's own path, whose cosine is below 1
    below = np.nextafter(LARGE_THETA, 0.0)
    assert jacobi_rotation(1e4)[1] < 1.0
    assert jacobi_rotation(below) == _jacobi_rotation_formula(below)
    assert jacobi_rotation(LARGE_THETA) == (1 / 2**28, 1.0)
    t, c = jacobi_rotation(-np.inf)
    assert (t, c) == (0.0, 1.0) and np.signbit(t)
