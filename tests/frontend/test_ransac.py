"""v2's RANSAC against numbers worked out by hand from its formulas (node.cpp, misc.cpp)."""

import numba
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.frontend.ransac import (
    JACOBI_SWEEPS,
    LARGE_THETA,
    LARGE_THETA_OVERFLOWS,
    _largest_eigenvector,
    _settled,
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


@numba.njit(error_model="numpy")
def _eigenvector_after_every_sweep(matrix):
    """The Jacobi solve as it ran before it stopped at _settled: every sweep until the
    off-diagonal part is zero or a sweep changes no bit."""
    vectors = np.eye(4)
    for _ in range(JACOBI_SWEEPS):
        off = 0.0
        for p in range(3):
            for q in range(p + 1, 4):
                off += matrix[p, q] * matrix[p, q]
        if off == 0.0:
            break
        matrix_before, vectors_before = matrix.copy(), vectors.copy()
        for p in range(3):
            for q in range(p + 1, 4):
                if matrix[p, q] == 0.0:
                    continue
                t, c = jacobi_rotation((matrix[q, q] - matrix[p, p]) / (2.0 * matrix[p, q]))
                s = t * c
                for k in range(4):
                    kp, kq = matrix[k, p], matrix[k, q]
                    matrix[k, p], matrix[k, q] = c * kp - s * kq, s * kp + c * kq
                for k in range(4):
                    pk, qk = matrix[p, k], matrix[q, k]
                    matrix[p, k], matrix[q, k] = c * pk - s * qk, s * pk + c * qk
                for k in range(4):
                    kp, kq = vectors[k, p], vectors[k, q]
                    vectors[k, p], vectors[k, q] = c * kp - s * kq, s * kp + c * kq
        same = True
        for i in range(4):
            for j in range(4):
                for old, new in ((matrix_before[i, j], matrix[i, j]), (vectors_before[i, j], vectors[i, j])):
                    if not (old == new and np.copysign(1.0, old) == np.copysign(1.0, new)):
                        same = False
        if same:
            break
    best = 0
    for k in range(1, 4):
        if matrix[k, k] > matrix[best, best]:
            best = k
    return vectors[:, best].copy()


def _horn(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Horn's symmetric 4x4 matrix of the correlation of two centred point sets."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = (source - source.mean(0)).T @ (target - target.mean(0))
    return np.array(
        [
            [m00 + m11 + m22, m12 - m21, m20 - m02, m01 - m10],
            [m12 - m21, m00 - m11 - m22, m01 + m10, m20 + m02],
            [m20 - m02, m01 + m10, m11 - m00 - m22, m12 + m21],
            [m01 - m10, m20 + m02, m12 + m21, m22 - m00 - m11],
        ]
    )


def _symmetric_matrices(rng: np.random.Generator, count: int) -> list[np.ndarray]:
    """Horn matrices of four-point fits at scales from micrometres to kilometres, symmetric
    matrices with eigenvalues as close as 1e-13 of their size, repeated or zero, diagonal
    ones, and one with NaN and infinity, also at a subnormal scale."""
    matrices = []
    for _ in range(count):
        scale = 10.0 ** rng.uniform(-6, 3)
        source = rng.normal(size=(4, 3)) * scale
        rotation = Rotation.from_rotvec(rng.normal(size=3) * rng.uniform(0, 0.3)).as_matrix()
        target = source @ rotation.T + rng.normal(size=(4, 3)) * scale * rng.choice([0.0, 1e-9, 1e-3, 0.3])
        matrices.append(_horn(source, target))
        basis = Rotation.random(random_state=rng).as_matrix()
        quaternion_basis = np.linalg.qr(rng.normal(size=(4, 4)))[0]
        eigenvalues = rng.normal(size=4) * 10.0 ** rng.uniform(-5, 5)
        eigenvalues[1] = eigenvalues[0] * (1 + rng.choice([0.0, 1e-13, 1e-10, 1e-6]))
        eigenvalues[2] = rng.choice([eigenvalues[2], 0.0])
        near = quaternion_basis @ np.diag(eigenvalues) @ quaternion_basis.T
        matrices.append((near + near.T) / 2)
        matrices.append(np.diag(np.append(np.diag(basis), 1.0)))
    broken = matrices[-2].copy()
    broken[0, 2], broken[3, 1] = np.nan, np.inf
    return [*matrices, broken, broken * 1e-300]


def test_the_jacobi_solve_ends_early_with_the_same_vector_to_the_bit():
    rng = np.random.default_rng(7)
    for matrix in _symmetric_matrices(rng, 2000):
        expected = _eigenvector_after_every_sweep(matrix.copy())
        assert [_bits(v) for v in _largest_eigenvector(matrix.copy())] == [_bits(v) for v in expected], matrix


def test_a_solve_settles_only_once_the_off_diagonal_part_is_below_the_last_bits():
    vectors = np.linalg.qr(np.random.default_rng(0).normal(size=(4, 4)))[0]  # no entry near zero
    horn = np.diag([0.3, -0.1, 0.05, -0.25])
    horn[0, 1] = horn[1, 0] = 1e-30
    assert _settled(horn, vectors)
    assert not _settled(horn, np.eye(4))  # a rotation to come would move a zero entry of the vectors
    horn[0, 1] = horn[1, 0] = 1e-9  # the rotation to come still moves the vectors' last bits
    assert not _settled(horn, vectors)
    horn[0, 1] = horn[1, 0] = 1e-30
    for value in (np.nan, np.inf):
        broken = horn.copy()
        broken[2, 3] = value
        assert not _settled(broken, vectors)
    assert not _settled(horn, np.where(vectors > 0.8, np.nan, vectors))
    twin = np.diag([0.3, 0.3, 0.05, -0.25])  # equal eigenvalues: rotations of any size to come
    twin[0, 1] = twin[1, 0] = 1e-300
    assert not _settled(twin, vectors)
