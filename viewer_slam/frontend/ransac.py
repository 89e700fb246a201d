"""Rigid motion between two sets of 3D correspondences by RANSAC, as RGB-D SLAM v2 estimates it.

v2 (``node.cpp``: ``getRelativeTransformationTo``, ``computeInliersAndError``,
``sample_matches_prefer_by_distance``; ``misc.cpp``: ``errorFunction2``;
``transformation_estimation_euclidean.cpp``: ``getTransformFromMatches``):

- the matches arrive sorted best first; each hypothesis comes from four distinct matches,
  each drawn as the smaller of two uniform indices, so good matches are drawn more often;
- a hypothesis is the closed-form fit weighted by ``1 / (z_source z_target)``;
- a correspondence is an inlier when its squared Mahalanobis distance under the Kinect
  noise model is at most ``max_dist_for_inliers``²; a hypothesis is refined by refitting
  on its inliers while that keeps or raises their number without raising their RMS
  distance (at most 19 refits), and it counts only with ``min_inliers`` inliers and an
  RMS distance within ``max_dist_for_inliers``;
- the best refined hypothesis has at least as many inliers and no larger RMS distance
  than every earlier best; a hypothesis with more than half (three quarters) of the
  matches as inliers counts for 11 (21) iterations, and one with more than 80 % ends the search;
- when no hypothesis counted, the identity (no motion) is tried.

The hypotheses are drawn in the same order as v2 draws them and are refined in batches
(one SVD and one set of 3x3 solves per batch), then taken in order with v2's bookkeeping,
so the result is that of drawing them one by one.
"""

from dataclasses import dataclass

import numpy as np

from ..geometry.align import rigid_transforms

SAMPLE_SIZE = 4
MAX_REFINEMENTS = 19
# errorFunction2's lateral noise: 3 pixels of a 640x480 Kinect with a 58 x 45 degree field of
# view, as an angle; the lateral variance is this squared times the depth (v2's model).
RASTER_COV_X = (3 * np.tan(np.radians(58.0) / 640)) ** 2
RASTER_COV_Y = (3 * np.tan(np.radians(45.0) / 480)) ** 2
# Squared distances beyond this many times the two points' largest variances are outliers
# without the full Mahalanobis test (errorFunction2's shortcut).
SHORTCUT_FACTOR = 2.0
BATCH = 25


@dataclass
class RansacResult:
    """``transform`` maps source points onto target points; ``inliers`` is a mask over
    the correspondences; ``rms_mahalanobis`` is v2's error, the RMS Mahalanobis distance of the inliers."""

    transform: np.ndarray
    inliers: np.ndarray
    rms_mahalanobis: float

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


def depth_variance(z: np.ndarray, sigma_depth: float) -> np.ndarray:
    """Kinect depth variance: standard deviation ``sigma_depth * z²`` (v2's ``depth_covariance``)."""
    return (sigma_depth * z * z) ** 2


def mahalanobis_squared(transforms: np.ndarray, source: np.ndarray, target: np.ndarray,
                        sigma_depth: float) -> np.ndarray:
    """v2's ``errorFunction2`` ``(H, N)``: squared Mahalanobis distance of ``T source - target``.

    Each point's covariance is ``diag(RASTER_COV_X z, RASTER_COV_Y z, depth_variance(z))``;
    the source one enters as ``R^T C R`` (v2's form) and the two are summed. Pairs farther
    apart than the shortcut allows are infinitely far.
    """
    rotations, translations = transforms[:, :3, :3], transforms[:, :3, 3]
    delta = np.einsum("hij,nj->hni", rotations, source) + translations[:, None] - target
    z_source, z_target = source[:, 2], target[:, 2]
    depth_source, depth_target = depth_variance(z_source, sigma_depth), depth_variance(z_target, sigma_depth)
    source_cov = np.stack([RASTER_COV_X * z_source, RASTER_COV_Y * z_source, depth_source], axis=1)
    target_cov = np.stack([RASTER_COV_X * z_target, RASTER_COV_Y * z_target, depth_target], axis=1)
    covariance = np.einsum("nk,hki,hkj->hnij", source_cov, rotations, rotations)
    covariance[..., [0, 1, 2], [0, 1, 2]] += target_cov
    distances = np.einsum("hni,hni->hn", delta, np.linalg.solve(covariance, delta[..., None])[..., 0])
    shortcut = SHORTCUT_FACTOR * (np.maximum(RASTER_COV_X, depth_source) + np.maximum(RASTER_COV_X, depth_target))
    distances[np.sum(delta * delta, axis=2) > shortcut] = np.inf
    return distances


def preferred_samples(count: int, hypotheses: int, rng: np.random.Generator,
                      size: int = SAMPLE_SIZE) -> list[np.ndarray]:
    """``hypotheses`` sets of ``size`` distinct indices into ``count`` best-first matches,
    each index the smaller of two uniform draws (``sample_matches_prefer_by_distance``)."""
    samples = []
    for _ in range(hypotheses):
        chosen: set[int] = set()
        while len(chosen) < size:
            chosen.add(int(rng.integers(count, size=2).min()))
        samples.append(np.array(sorted(chosen)))
    return samples


def _score(transforms: np.ndarray, source, target, sigma_depth, threshold) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inlier masks, counts and RMS Mahalanobis distances (1e9 below three inliers) per hypothesis."""
    distances = mahalanobis_squared(transforms, source, target, sigma_depth)
    inliers = distances <= threshold
    counts = inliers.sum(axis=1)
    mean = np.where(inliers, distances, 0.0).sum(axis=1) / np.maximum(counts, 1)
    return inliers, counts, np.where(counts >= 3, np.sqrt(mean), 1e9)


def _refine(samples: list[np.ndarray], source, target, weights, sigma_depth, max_distance,
            min_inliers) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Refine each sampled hypothesis as v2 does; (transforms, inlier masks, counts, errors),
    count 0 for a hypothesis that never reached ``min_inliers`` within ``max_distance``."""
    hypotheses, count = len(samples), len(source)
    masks = np.zeros((hypotheses, count), dtype=bool)
    for h, sample in enumerate(samples):
        masks[h, sample] = True
    best_transforms = np.tile(np.eye(4), (hypotheses, 1, 1))
    best_masks = np.zeros_like(masks)
    best_counts = np.zeros(hypotheses, dtype=int)
    best_errors = np.full(hypotheses, 1e6)
    active = np.ones(hypotheses, dtype=bool)
    for _ in range(MAX_REFINEMENTS):
        if not active.any():
            break
        rows = np.flatnonzero(active)
        transforms = rigid_transforms(np.broadcast_to(source, (len(rows), count, 3)),
                                      np.broadcast_to(target, (len(rows), count, 3)), masks[rows] * weights)
        inliers, counts, errors = _score(transforms, source, target, sigma_depth, max_distance ** 2)
        hopeless = (counts < min_inliers) | (errors > max_distance)
        better = ~hopeless & (counts >= best_counts[rows]) & (errors <= best_errors[rows])
        unchanged = better & (counts == best_counts[rows])
        taken = rows[better]
        best_transforms[taken], best_masks[taken] = transforms[better], inliers[better]
        best_counts[taken], best_errors[taken] = counts[better], errors[better]
        masks[rows] = inliers
        active[rows[~better | unchanged]] = False
    return best_transforms, best_masks, best_counts, best_errors


def ransac_rigid(source: np.ndarray, target: np.ndarray, *, iterations: int, max_mahalanobis: float,
                 min_inliers: int, sigma_depth: float, rng: np.random.Generator) -> RansacResult | None:
    """The rigid transform best supported by correspondences ``source[i] <-> target[i]``,
    ordered best match first, or None when it has fewer than ``min_inliers`` inliers.

    ``min_inliers`` is lowered to three quarters of the correspondences when that is less (v2).
    """
    count = len(source)
    if count < SAMPLE_SIZE:
        return None
    min_inliers = min(min_inliers, int(0.75 * count))
    weights = 1.0 / (source[:, 2] * target[:, 2])
    best = (np.eye(4), np.zeros(count, dtype=bool), 0, 1e6)
    valid, drawn = 0, 0
    while drawn < iterations:
        samples = preferred_samples(count, min(BATCH, iterations - drawn), rng)
        refined = _refine(samples, source, target, weights, sigma_depth, max_mahalanobis, min_inliers)
        for transform, mask, inliers, error in zip(*refined):
            drawn += 1
            if inliers == 0:
                continue
            valid += 1
            if error <= best[3] and inliers >= best[2] and inliers >= min_inliers:
                best = (transform, mask, int(inliers), float(error))
                drawn += 10 * int(inliers > 0.5 * count) + 10 * int(inliers > 0.75 * count)
                if inliers > 0.8 * count:
                    drawn = iterations
            if drawn >= iterations:
                break
    if valid == 0:
        inliers, counts, errors = _score(np.eye(4)[None], source, target, sigma_depth, max_mahalanobis ** 2)
        if counts[0] > min_inliers and errors[0] < max_mahalanobis:
            best = (np.eye(4), inliers[0], int(counts[0]), float(errors[0]))
    transform, mask, inliers, error = best
    if inliers < max(min_inliers, 3):
        return None
    return RansacResult(transform, mask, error)
