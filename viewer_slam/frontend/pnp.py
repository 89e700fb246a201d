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

The hypotheses are OpenCV's EPnP; the draws and each hypothesis' reprojection errors are
compiled (numba), the same to the bit as ``cv::RNG`` and ``cv::projectPoints`` give them, so
that a registration costs little more than its EPnP solutions.
"""

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..compiled import jit
from ..geometry.se3 import invert, make_pose

RANSAC_CONFIDENCE = 0.99
SAMPLE_SIZE = 6  # cv3::solvePnPRansac's EPnP sample
RNG_MULTIPLIER = np.uint64(4164903690)  # cv::RNG's multiply-with-carry (CV_RNG_COEFF)
RNG_SEED = np.uint64((1 << 64) - 1)  # RNG((uint64)-1)
LOW_32 = np.uint64((1 << 32) - 1)
HIGH_SHIFT = np.uint64(32)
EVERY_ERROR = np.float32(np.inf)  # a threshold no error exceeds: every point counted, none skipped
DISTORTION_COEFFICIENTS = 14  # OpenCV's longest model: k1 k2 p1 p2 k3 k4 k5 k6 s1..s4 tau_x tau_y
PLAIN_COEFFICIENTS = 5  # k1 k2 p1 p2 k3


@dataclass
class PnpResult:
    """``pose`` is the camera in the frame of the 3D points (``T_points_camera``)."""

    pose: np.ndarray
    inliers: np.ndarray

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


@jit
def distinct_samples(count, hypotheses):
    """``getSubset`` for each of ``hypotheses`` iterations in turn: SAMPLE_SIZE distinct indices
    into ``count`` correspondences, drawn by ``cv::RNG((uint64)-1)``, a repeated draw drawn again.

    ``cv::RNG`` is a 64-bit multiply-with-carry generator whose ``uniform(0, count)`` is its next
    state's low 32 bits modulo ``count``; the samples do not depend on the hypotheses' outcome,
    so every iteration's is drawn up front.
    """
    samples = np.empty((hypotheses, SAMPLE_SIZE), dtype=np.int64)
    state, modulus = RNG_SEED, np.uint64(count)
    for hypothesis in range(hypotheses):
        chosen = 0
        while chosen < SAMPLE_SIZE:
            state = (state & LOW_32) * RNG_MULTIPLIER + (state >> HIGH_SHIFT)
            index = np.int64((state & LOW_32) % modulus)
            repeated = False
            for k in range(chosen):
                repeated |= samples[hypothesis, k] == index
            if not repeated:
                samples[hypothesis, chosen] = index
                chosen += 1
    return samples


def iterations_needed(confidence: float, outlier_ratio: float, sample_size: int, most: int) -> int:
    """``RANSACUpdateNumIters``: the iterations for ``confidence`` of one all-inlier sample."""
    outlier_ratio = min(max(outlier_ratio, 0.0), 1.0)
    numerator = math.log(max(1.0 - confidence, np.finfo(float).tiny))
    clean = 1.0 - (1.0 - outlier_ratio) ** sample_size
    if clean < np.finfo(float).tiny:
        return 0
    denominator = math.log(clean)
    return most if denominator >= 0 or -numerator >= most * -denominator else int(round(numerator / denominator))


@dataclass(frozen=True)
class Lens:
    """A camera as ``cv::projectPoints`` reads it: the intrinsics, the distortion coefficients
    padded to OpenCV's fourteen, and the tilted-sensor matrix they imply. ``plain``: at most
    the five-coefficient model (k1 k2 p1 p2 k3), whose pixels the projection reaches without
    the rational, thin-prism and tilt terms, which add exact zeros and multiply by exact ones."""

    intrinsics: np.ndarray
    coefficients: np.ndarray
    tilt: np.ndarray
    plain: bool

    @classmethod
    def of(cls, K: np.ndarray, distortion: np.ndarray | None) -> "Lens":
        coefficients = np.zeros(DISTORTION_COEFFICIENTS)
        if distortion is not None:
            coefficients[: len(distortion)] = distortion
        tilted = distortion is not None and len(distortion) == DISTORTION_COEFFICIENTS
        return cls(
            np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]], dtype=np.float64),
            coefficients,
            _tilt_matrix(coefficients[12], coefficients[13]) if tilted else np.eye(3),
            not coefficients[PLAIN_COEFFICIENTS:].any(),
        )


def _tilt_matrix(tau_x: float, tau_y: float) -> np.ndarray:
    """``computeTiltProjectionMatrix``, its products summed in OpenCV's order (``Matx``'s)."""
    cos_x, sin_x, cos_y, sin_y = math.cos(tau_x), math.sin(tau_x), math.cos(tau_y), math.sin(tau_y)
    rotation_x = np.array([[1, 0, 0], [0, cos_x, sin_x], [0, -sin_x, cos_x]], dtype=np.float64)
    rotation_y = np.array([[cos_y, 0, -sin_y], [0, 1, 0], [sin_y, 0, cos_y]], dtype=np.float64)
    rotation = _matx_product(rotation_y, rotation_x)
    projection = np.array(
        [[rotation[2, 2], 0, -rotation[0, 2]], [0, rotation[2, 2], -rotation[1, 2]], [0, 0, 1]], dtype=np.float64
    )
    return _matx_product(projection, rotation)


def _matx_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    product = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            total = 0.0
            for k in range(3):
                total += float(a[i, k]) * float(b[k, j])
            product[i, j] = total
    return product


@jit
def _reprojection_errors(objects, pixels, rotation, translation, intrinsics, k, tilt, plain, threshold, to_beat):
    """``cvProjectPoints2Internal`` for each point, operation for operation in float64, its
    pixel rounded to float32 (the caller's points are float32), then the distance to the
    observed pixel as RTAB-Map's copy takes it: the offset in float32, the distance in
    float64 rounded to float32; and how many of those errors are within ``threshold``.
    With a ``plain`` lens (:class:`Lens`) the terms that add zeros and multiply by ones are
    left out: the same errors wherever the projection is finite (where it overflows, an
    infinite error instead of a NaN, neither within any threshold).

    The points are taken in order until those left could no longer take that count above
    ``to_beat``: RANSAC needs no more of a hypothesis that cannot become the best. The count is
    then at most ``to_beat`` and the errors of the points not reached are left unset."""
    fx, fy, cx, cy = intrinsics[0], intrinsics[1], intrinsics[2], intrinsics[3]
    count = objects.shape[0]
    errors = np.empty(count, dtype=np.float32)
    within = 0
    for n in range(count):
        if within + count - n <= to_beat:
            break
        X, Y, Z = np.float64(objects[n, 0]), np.float64(objects[n, 1]), np.float64(objects[n, 2])
        x = rotation[0, 0] * X + rotation[0, 1] * Y + rotation[0, 2] * Z + translation[0]
        y = rotation[1, 0] * X + rotation[1, 1] * Y + rotation[1, 2] * Z + translation[1]
        z = rotation[2, 0] * X + rotation[2, 1] * Y + rotation[2, 2] * Z + translation[2]
        z = 1.0 / z if z != 0.0 else 1.0
        x *= z
        y *= z
        r2 = x * x + y * y
        r4 = r2 * r2
        r6 = r4 * r2
        a1 = 2 * x * y
        a2 = r2 + 2 * x * x
        a3 = r2 + 2 * y * y
        cdist = 1 + k[0] * r2 + k[1] * r4 + k[4] * r6
        if plain:
            u = np.float32((x * cdist + k[2] * a1 + k[3] * a2) * fx + cx)
            v = np.float32((y * cdist + k[2] * a3 + k[3] * a1) * fy + cy)
        else:
            icdist2 = 1.0 / (1 + k[5] * r2 + k[6] * r4 + k[7] * r6)
            xd0 = x * cdist * icdist2 + k[2] * a1 + k[3] * a2 + k[8] * r2 + k[9] * r4
            yd0 = y * cdist * icdist2 + k[2] * a3 + k[3] * a1 + k[10] * r2 + k[11] * r4
            # the tilt matrix times (xd0, yd0, 1), summed as Matx sums: from 0, in column order
            tilted_x = 0.0 + tilt[0, 0] * xd0 + tilt[0, 1] * yd0 + tilt[0, 2] * 1.0
            tilted_y = 0.0 + tilt[1, 0] * xd0 + tilt[1, 1] * yd0 + tilt[1, 2] * 1.0
            tilted_z = 0.0 + tilt[2, 0] * xd0 + tilt[2, 1] * yd0 + tilt[2, 2] * 1.0
            inverse = 1.0 / tilted_z if tilted_z != 0.0 else 1.0
            u = np.float32((inverse * tilted_x) * fx + cx)
            v = np.float32((inverse * tilted_y) * fy + cy)
        du, dv = np.float64(pixels[n, 0] - u), np.float64(pixels[n, 1] - v)
        errors[n] = np.float32(np.sqrt(du * du + dv * dv))
        if errors[n] <= threshold:
            within += 1
    return errors, within


def reprojection_errors(
    objects: np.ndarray, pixels: np.ndarray, lens: Lens, rvec: np.ndarray, tvec: np.ndarray
) -> np.ndarray:
    """Each correspondence's reprojection distance in pixels, float32, the same to the bit as
    ``cv2.projectPoints`` and RTAB-Map's copy compute it (float32 ``objects`` and ``pixels``)."""
    errors, _ = _reprojection_errors(
        objects,
        pixels,
        cv2.Rodrigues(rvec)[0],
        np.asarray(tvec, dtype=np.float64).ravel(),
        lens.intrinsics,
        lens.coefficients,
        lens.tilt,
        lens.plain,
        EVERY_ERROR,
        -1,
    )
    return errors


def refine(
    objects: np.ndarray,
    pixels: np.ndarray,
    K: np.ndarray,
    distortion: np.ndarray | None,
    lens: Lens,
    rvec: np.ndarray,
    tvec: np.ndarray,
    inliers: np.ndarray,
    distance: float,
    iterations: int,
    min_inliers: int,
) -> tuple[np.ndarray, np.ndarray]:
    """``util3d::solvePnPRansac``'s refinement of RANSAC's pose (module docstring)."""
    current, threshold = inliers, np.float32(distance)
    for _ in range(iterations):
        _, rvec, tvec = cv2.solvePnP(
            objects[current], pixels[current], K, distortion, rvec, tvec, True, cv2.SOLVEPNP_ITERATIVE
        )
        errors = reprojection_errors(objects, pixels, lens, rvec, tvec)
        counted = np.flatnonzero(errors <= threshold)
        if len(counted) < min_inliers or np.array_equal(counted, current):
            break
        threshold = np.float32(min(distance, 3.0 * math.sqrt(float(np.var(errors[counted])))))
        current = counted
    return rvec, tvec


def solve_pnp_ransac(
    object_points: np.ndarray,
    image_points: np.ndarray,
    K: np.ndarray,
    *,
    reprojection_error: float,
    iterations: int,
    min_inliers: int,
    distortion: tuple[float, ...] | None = None,
    refine_iterations: int = 0,
    refine_distance: float | None = None,
) -> PnpResult | None:
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
    coefficients = np.asarray(distortion, dtype=np.float64) if distortion is not None and any(distortion) else None
    lens = Lens.of(K, coefficients)
    threshold = np.float32(reprojection_error)
    best: tuple[np.ndarray, np.ndarray] | None = None
    best_mask, best_count, budget, iteration = np.zeros(count, bool), 0, max(iterations, 1), 0
    samples = distinct_samples(count, budget)
    sample_objects, sample_pixels = objects[samples], pixels[samples]
    while iteration < budget:
        drawn_objects, drawn_pixels = sample_objects[iteration], sample_pixels[iteration]
        iteration += 1
        try:
            solved, rvec, tvec = cv2.solvePnP(drawn_objects, drawn_pixels, K, coefficients, flags=cv2.SOLVEPNP_EPNP)
        except cv2.error:
            continue  # a degenerate sample: no model, as runKernel's 0
        if not solved:
            continue
        to_beat = max(best_count, SAMPLE_SIZE - 1)
        errors, agreeing = _reprojection_errors(
            objects,
            pixels,
            cv2.Rodrigues(rvec)[0],
            tvec.ravel(),
            lens.intrinsics,
            lens.coefficients,
            lens.tilt,
            lens.plain,
            threshold,
            to_beat,
        )
        if agreeing > to_beat:  # so every error was computed
            best, best_mask, best_count = (rvec, tvec), errors <= threshold, agreeing
            budget = iterations_needed(RANSAC_CONFIDENCE, (count - agreeing) / count, SAMPLE_SIZE, budget)
    if best is None or best_count < max(min_inliers, 4):
        return None
    rvec, tvec = best
    if refine_iterations > 0:
        rvec, tvec = refine(
            objects,
            pixels,
            K,
            coefficients,
            lens,
            rvec,
            tvec,
            np.flatnonzero(best_mask),
            refine_distance if refine_distance is not None else reprojection_error,
            refine_iterations,
            max(min_inliers, 4),
        )
    return PnpResult(invert(make_pose(cv2.Rodrigues(rvec)[0], np.asarray(tvec).ravel())), best_mask)
