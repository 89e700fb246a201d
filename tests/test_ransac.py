import numpy as np
import pytest

from viewer_slam.frontend.ransac import (mahalanobis_squared, point_variances, ransac_rigid, rigid_transforms)
from viewer_slam.geometry.se3 import exp_so3, make_pose, transform_points


def random_pose(rng, angle=0.5, shift=0.5):
    return make_pose(exp_so3(rng.normal(size=3) * angle), rng.normal(size=3) * shift)


def scene(rng, count):
    """Points as an RGB-D camera sees them: in front of it, 0.5-4 m away."""
    return rng.uniform([-1.5, -1.0, 0.5], [1.5, 1.0, 4.0], size=(count, 3))


def test_batched_solver_recovers_each_exact_transform():
    rng = np.random.default_rng(1)
    truths = np.stack([random_pose(rng, angle=2.0) for _ in range(64)])
    source = rng.normal(size=(64, 3, 3))
    target = np.einsum("hij,hnj->hni", truths[:, :3, :3], source) + truths[:, None, :3, 3]
    np.testing.assert_allclose(rigid_transforms(source, target), truths, atol=1e-9)


def test_batched_solver_never_returns_a_reflection():
    rng = np.random.default_rng(2)
    source = rng.normal(size=(100, 3, 3))
    target = source * np.array([1.0, 1.0, -1.0])  # a mirror image: the best rotation is not the mirror
    rotations = rigid_transforms(source, target)[:, :3, :3]
    np.testing.assert_allclose(np.linalg.det(rotations), 1.0, atol=1e-9)


def test_mahalanobis_distance_matches_the_full_covariance_for_axis_aligned_rotations():
    rng = np.random.default_rng(3)
    source, target = scene(rng, 20), scene(rng, 20)
    source_var, target_var = point_variances(source, 3.0, 525.0), point_variances(target, 3.0, 525.0)
    swap_xz = make_pose(np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]), [0.1, 0.2, 0.3])
    residual = transform_points(swap_xz, source) - target
    covariance = np.einsum("ij,nj,kj->nik", swap_xz[:3, :3], source_var, swap_xz[:3, :3]) + np.einsum(
        "ni,ij->nij", target_var, np.eye(3))
    expected = np.einsum("ni,nij,nj->n", residual, np.linalg.inv(covariance), residual)
    np.testing.assert_allclose(mahalanobis_squared(swap_xz[None], source, target, source_var, target_var)[0],
                               expected, rtol=1e-12)


def test_noise_grows_with_depth():
    variances = point_variances(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 3.0]]), 3.0, 525.0)
    assert np.all(variances[1] > variances[0])
    assert variances[1, 2] / variances[0, 2] == pytest.approx(81.0)  # sigma_z ~ z^2


def test_ransac_finds_the_motion_among_half_outliers_and_flags_them():
    rng = np.random.default_rng(4)
    truth = random_pose(rng, angle=0.3, shift=0.3)
    source = scene(rng, 300)
    target = transform_points(truth, source)
    target += rng.normal(size=(300, 3)) * np.sqrt(point_variances(target, 1.0, 525.0))  # the sensor's own noise
    outliers = rng.permutation(300)[:150]
    target[outliers] = scene(rng, 150)
    variances = point_variances(source, 3.0, 525.0)
    result = ransac_rigid(source, target, variances, point_variances(target, 3.0, 525.0), iterations=200,
                          max_mahalanobis=3.0, rng=np.random.default_rng(0), min_inliers=20)
    assert result is not None
    np.testing.assert_allclose(result.transform[:3, 3], truth[:3, 3], atol=0.003)
    np.testing.assert_allclose(result.transform[:3, :3], truth[:3, :3], atol=0.003)
    is_outlier = np.isin(np.arange(300), outliers)
    # Random outliers can land near their counterpart by chance; almost none may. A 3-sigma
    # test in three dimensions keeps 97 % of the true inliers.
    assert np.count_nonzero(result.inliers & is_outlier) <= 3
    assert np.count_nonzero(result.inliers & ~is_outlier) >= 0.95 * 150
    # The refit is the least-squares fit on the inliers: no worse there than the truth.
    truth_residual = transform_points(truth, source[result.inliers]) - target[result.inliers]
    assert result.rms_error <= np.sqrt(np.mean(np.sum(truth_residual ** 2, axis=1))) + 1e-12


def test_ransac_refuses_pure_noise():
    rng = np.random.default_rng(5)
    source, target = scene(rng, 200), scene(rng, 200)
    variances = point_variances(source, 3.0, 525.0)
    assert ransac_rigid(source, target, variances, point_variances(target, 3.0, 525.0), iterations=200,
                        max_mahalanobis=3.0, rng=np.random.default_rng(0), min_inliers=20) is None


def test_ransac_is_deterministic_for_a_seed():
    rng = np.random.default_rng(6)
    source = scene(rng, 100)
    target = transform_points(random_pose(rng), source) + rng.normal(scale=0.01, size=(100, 3))
    variances = point_variances(source, 3.0, 525.0)
    runs = [ransac_rigid(source, target, variances, variances, iterations=200, max_mahalanobis=3.0,
                         rng=np.random.default_rng(9)) for _ in range(2)]
    np.testing.assert_array_equal(runs[0].transform, runs[1].transform)
    np.testing.assert_array_equal(runs[0].inliers, runs[1].inliers)


def test_too_few_correspondences_give_no_transform():
    points = np.eye(3) + 1.0
    variances = point_variances(points, 3.0, 525.0)
    assert ransac_rigid(points[:2], points[:2], variances[:2], variances[:2], iterations=10, max_mahalanobis=3.0,
                        rng=np.random.default_rng(0)) is None
