"""3D-2D registration: PnP RANSAC as RTAB-Map runs it.

RTAB-Map compiles in its own copy of OpenCV 3.0's ``solvePnPRansac``
(``corelib/src/opencv/solvepnp.cpp``, called by ``util3d::solvePnPRansac``), and its RANSAC
decides when a registration succeeds: after a loss, the frames whose matches hold too few
inliers for it to find are the frames where tracking does not resume yet. So this module
follows that copy step by step:

- hypotheses are EPnP poses of six distinct correspondences drawn by ``cv::RNG`` seeded with
  ``(uint64)-1`` (a fresh generator per call, so the same input gives the same pose);
- a correspondence is an inlier when its reprojection lies within the threshold (compared
  in float32, as there);
- a hypothesis replaces the best when it has more inliers (at least six), and the number of
  iterations then shrinks to what 0.99 confidence needs with that inlier ratio
  (``RANSACUpdateNumIters``), at most ``iterations``;
- the result is the best hypothesis' pose and inliers (the copy fits the inliers again but
  returns the sample's pose); then ``util3d::solvePnPRansac`` refines that pose
  Vis/PnPRefineIterations times: OpenCV's iterative PnP from it on the current inliers, the
  inliers counted again within Vis/PnPReprojError (the plain distance now) and the next
  threshold ``min(Vis/PnPReprojError, 3 σ)`` of their errors, until the set no longer
  changes or falls under the minimum; it returns the refined pose with RANSAC's inliers.
"""

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..geometry.se3 import invert, make_pose

RANSAC_CONFIDENCE = 0.99
SAMPLE_SIZE = 6                            # cv3::solvePnPRansac's EPnP sample
RNG_MULTIPLIER = 4164903690                # cv::RNG's multiply-with-carry (CV_RNG_COEFF)
RNG_SEED = (1 << 64) - 1                   # RNG((uint64)-1)
_LOW_32 = (1 << 32) - 1


@dataclass
class PnpResult:
    """``pose`` is the camera in the frame of the 3D points (``T_points_camera``)."""

    pose: np.ndarray
    inliers: np.ndarray

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


class OpenCvRng:
    """``cv::RNG``: a 64-bit multiply-with-carry generator; ``uniform(a, b)`` draws in [a, b)."""

    def __init__(self, state: int = RNG_SEED):
        self.state = state

    def next(self) -> int:
        self.state = ((self.state & _LOW_32) * RNG_MULTIPLIER + (self.state >> 32)) & ((1 << 64) - 1)
        return self.state & _LOW_32

    def uniform(self, low: int, high: int) -> int:
        return low if low == high else low + self.next() % (high - low)


def iterations_needed(confidence: float, outlier_ratio: float, sample_size: int, most: int) -> int:
    """``RANSACUpdateNumIters``: the iterations for ``confidence`` of one all-inlier sample."""
    outlier_ratio = min(max(outlier_ratio, 0.0), 1.0)
    numerator = math.log(max(1.0 - confidence, np.finfo(float).tiny))
    clean = 1.0 - (1.0 - outlier_ratio) ** sample_size
    if clean < np.finfo(float).tiny:
        return 0
    denominator = math.log(clean)
    return most if denominator >= 0 or -numerator >= most * -denominator else int(round(numerator / denominator))


def distinct_sample(rng: OpenCvRng, count: int) -> np.ndarray:
    """``getSubset``: SAMPLE_SIZE distinct indices, a repeated draw drawn again."""
    chosen: list[int] = []
    while len(chosen) < SAMPLE_SIZE:
        index = rng.uniform(0, count)
        if index not in chosen:
            chosen.append(index)
    return np.array(chosen)


def refine(objects: np.ndarray, pixels: np.ndarray, K: np.ndarray, lens: np.ndarray | None, rvec: np.ndarray,
           tvec: np.ndarray, inliers: np.ndarray, distance: float, iterations: int,
           min_inliers: int) -> tuple[np.ndarray, np.ndarray]:
    """``util3d::solvePnPRansac``'s refinement of RANSAC's pose (module docstring)."""
    current, threshold = inliers, np.float32(distance)
    for _ in range(iterations):
        _, rvec, tvec = cv2.solvePnP(objects[current], pixels[current], K, lens, rvec, tvec, True,
                                     cv2.SOLVEPNP_ITERATIVE)
        errors = reprojection_errors(objects, pixels, K, lens, rvec, tvec)
        counted = np.flatnonzero(errors <= threshold)
        if len(counted) < min_inliers or np.array_equal(counted, current):
            break
        threshold = np.float32(min(distance, 3.0 * math.sqrt(float(np.var(errors[counted])))))
        current = counted
    return rvec, tvec


def reprojection_errors(objects: np.ndarray, pixels: np.ndarray, K: np.ndarray, lens: np.ndarray | None,
                        rvec: np.ndarray, tvec: np.ndarray) -> np.ndarray:
    """Each correspondence's reprojection distance in pixels, in float32 as the copy computes it."""
    projected = cv2.projectPoints(objects, rvec, tvec, K, lens)[0].reshape(-1, 2).astype(np.float32)
    offset = (pixels - projected).astype(np.float64)
    return np.sqrt(offset[:, 0] ** 2 + offset[:, 1] ** 2).astype(np.float32)


def solve_pnp_ransac(object_points: np.ndarray, image_points: np.ndarray, K: np.ndarray, *,
                     reprojection_error: float, iterations: int, min_inliers: int,
                     distortion: tuple[float, ...] | None = None, refine_iterations: int = 0,
                     refine_distance: float | None = None) -> PnpResult | None:
    """Camera pose from 3D points ``(N, 3)`` seen at pixels ``(N, 2)``, or None when fewer
    than ``min_inliers`` (at least 4) correspondences agree with the best hypothesis.

    ``reprojection_error`` is the inlier distance in pixels (RTAB-Map's copy compares the
    distance with its threshold squared: its callers pass Vis/PnPReprojError², see
    ``RtabmapParams.pnp_inlier_distance``). ``distortion`` (OpenCV's k1, k2, p1, p2, k3) is
    the lens model of the pixels: TUM's freiburg1/2 images are not rectified. With
    ``refine_iterations`` the pose is refined (module docstring), the inliers recounted
    within ``refine_distance`` px (Vis/PnPReprojError itself).
    """
    count = len(object_points)
    if count < max(min_inliers, 4, SAMPLE_SIZE):
        return None
    objects = np.ascontiguousarray(object_points, dtype=np.float32)
    pixels = np.ascontiguousarray(image_points, dtype=np.float32)
    lens = np.asarray(distortion, dtype=np.float64) if distortion is not None and any(distortion) else None
    threshold = np.float32(reprojection_error)
    rng = OpenCvRng()
    best: tuple[np.ndarray, np.ndarray] | None = None
    best_mask, best_count, budget, iteration = np.zeros(count, bool), 0, max(iterations, 1), 0
    while iteration < budget:
        iteration += 1
        sample = distinct_sample(rng, count)
        try:
            solved, rvec, tvec = cv2.solvePnP(objects[sample], pixels[sample], K, lens, flags=cv2.SOLVEPNP_EPNP)
        except cv2.error:
            continue                                 # a degenerate sample: no model, as runKernel's 0
        if not solved:
            continue
        mask = reprojection_errors(objects, pixels, K, lens, rvec, tvec) <= threshold
        agreeing = int(mask.sum())
        if agreeing > max(best_count, SAMPLE_SIZE - 1):
            best, best_mask, best_count = (rvec, tvec), mask, agreeing
            budget = iterations_needed(RANSAC_CONFIDENCE, (count - agreeing) / count, SAMPLE_SIZE, budget)
    if best is None or best_count < max(min_inliers, 4):
        return None
    rvec, tvec = best
    if refine_iterations > 0:
        rvec, tvec = refine(objects, pixels, K, lens, rvec, tvec, np.flatnonzero(best_mask),
                            refine_distance if refine_distance is not None else reprojection_error,
                            refine_iterations, max(min_inliers, 4))
    return PnpResult(invert(make_pose(cv2.Rodrigues(rvec)[0], np.asarray(tvec).ravel())), best_mask)
