"""Rigid motion between two sets of 3D correspondences by RANSAC (RGB-D SLAM's estimator).

Hypotheses come from three sampled correspondences each (Horn/Umeyama on a triangle), all
solved at once with one batched SVD; a correspondence is an inlier when its residual is
small under the RGB-D sensor's noise model (Mahalanobis distance), and the best hypothesis
is refitted on all its inliers until the inlier set stops changing.
"""

from dataclasses import dataclass

import numpy as np

from ..geometry.align import align_umeyama

# Kinect depth noise grows with the square of the depth: sigma_z = 1.425e-3 z^2
# (Khoshelham & Elberink, Sensors 2012).
DEPTH_NOISE_COEFFICIENT = 1.425e-3
# Triangles with a side shorter than this give ill-conditioned rotations.
MIN_SAMPLE_SPREAD_M = 0.02
MAX_REFITS = 10
# Hypotheses are solved and scored this many at a time; after each batch RANSAC stops if
# an all-inlier sample has been drawn with CONFIDENCE given the best inlier ratio so far.
BATCH = 50
CONFIDENCE = 0.999


@dataclass
class RansacResult:
    """``transform`` maps source points onto target points; ``inliers`` is a mask over
    the correspondences; ``rms_error`` is the RMS residual (metres) of the inliers."""

    transform: np.ndarray
    inliers: np.ndarray
    rms_error: float

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


def point_variances(points: np.ndarray, pixel_sigma: float, focal: float) -> np.ndarray:
    """Per-axis variances ``(N, 3)`` of camera-frame points measured by an RGB-D sensor:
    lateral noise from the keypoint's pixel uncertainty, axial noise from the depth."""
    z = points[:, 2]
    lateral = (pixel_sigma * z / focal) ** 2
    axial = (DEPTH_NOISE_COEFFICIENT * z * z) ** 2
    return np.stack([lateral, lateral, axial], axis=1)


def rigid_transforms(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least-squares rigid transforms ``(H, 4, 4)`` for point sets ``(H, M, 3)``, batched
    (Kabsch with the reflection fix); the hot path of RANSAC's hypothesis generation."""
    mean_source = source.mean(axis=1)
    mean_target = target.mean(axis=1)
    covariance = np.einsum("hmi,hmj->hij", target - mean_target[:, None], source - mean_source[:, None])
    U, _, Vt = np.linalg.svd(covariance)
    sign = np.sign(np.linalg.det(U @ Vt))
    U[:, :, 2] *= sign[:, None]
    rotation = U @ Vt
    transforms = np.zeros((len(source), 4, 4))
    transforms[:, :3, :3] = rotation
    transforms[:, :3, 3] = mean_target - np.einsum("hij,hj->hi", rotation, mean_source)
    transforms[:, 3, 3] = 1.0
    return transforms


def mahalanobis_squared(transforms: np.ndarray, source: np.ndarray, target: np.ndarray,
                        source_var: np.ndarray, target_var: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distances ``(H, N)`` of the residuals ``T source - target``.

    The source covariance is carried into the target frame through the diagonal of
    ``R diag(var) R^T`` (element-wise squared rotation), which keeps the test exact for
    axis-aligned rotations and costs one small matrix product per hypothesis.
    """
    distances = np.zeros((len(source), len(transforms)))
    for axis in range(3):  # one (N, H) plane per axis keeps the arithmetic on contiguous arrays
        row = transforms[:, axis, :3]
        residual = source @ row.T + transforms[:, axis, 3] - target[:, axis, None]
        variance = source_var @ (row * row).T + target_var[:, axis, None]
        distances += residual * residual / variance
    return distances.T


def _sample_triangles(points: np.ndarray, iterations: int, rng: np.random.Generator) -> np.ndarray:
    """``(H, 3)`` index triples of distinct, well-spread points (degenerate draws dropped)."""
    triples = rng.integers(0, len(points), size=(iterations, 3))
    corners = points[triples]
    sides = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    return triples[np.all(sides > MIN_SAMPLE_SPREAD_M, axis=1)]


def _iterations_needed(inlier_ratio: float) -> float:
    """Hypotheses after which an all-inlier triple was drawn with CONFIDENCE."""
    clean_triple = inlier_ratio ** 3
    if clean_triple >= 1.0:
        return 0.0
    if clean_triple <= 0.0:
        return np.inf
    return np.log(1.0 - CONFIDENCE) / np.log(1.0 - clean_triple)


def ransac_rigid(source: np.ndarray, target: np.ndarray, source_var: np.ndarray, target_var: np.ndarray,
                 *, iterations: int, max_mahalanobis: float, rng: np.random.Generator,
                 min_inliers: int = 3) -> RansacResult | None:
    """The rigid transform best supported by correspondences ``source[i] <-> target[i]``.

    ``*_var`` are per-point axis variances (:func:`point_variances`). At most ``iterations``
    hypotheses are drawn, in batches, stopping early once the best inlier ratio makes a
    better hypothesis unlikely. Returns None when no hypothesis gathers ``min_inliers``.
    """
    min_inliers = max(3, min_inliers)
    if len(source) < min_inliers:
        return None
    threshold = max_mahalanobis ** 2
    best_count, best_spread, transform, inliers = 0, np.inf, None, None
    drawn = 0
    while drawn < min(iterations, _iterations_needed(best_count / len(source))):
        batch = min(BATCH, iterations - drawn)
        drawn += batch
        triples = _sample_triangles(source, batch, rng)
        if not len(triples):
            continue
        hypotheses = rigid_transforms(source[triples], target[triples])
        distances = mahalanobis_squared(hypotheses, source, target, source_var, target_var)
        inlying = distances < threshold
        counts = inlying.sum(axis=1)
        # Most inliers wins; among equals the smallest mean inlier distance.
        spread = np.where(inlying, distances, 0.0).sum(axis=1) / np.maximum(counts, 1)
        best = np.lexsort((spread, -counts))[0]
        if (counts[best], -spread[best]) > (best_count, -best_spread):
            best_count, best_spread = counts[best], spread[best]
            transform, inliers = hypotheses[best], inlying[best]
    if best_count < min_inliers:
        return None
    for _ in range(MAX_REFITS):
        transform = align_umeyama(source[inliers], target[inliers])
        refitted = mahalanobis_squared(transform[None], source, target, source_var, target_var)[0] < threshold
        if refitted.sum() < min_inliers or np.array_equal(refitted, inliers):
            break
        inliers = refitted
    residual = source[inliers] @ transform[:3, :3].T + transform[:3, 3] - target[inliers]
    return RansacResult(transform, inliers, float(np.sqrt(np.mean(np.sum(residual ** 2, axis=1)))))
