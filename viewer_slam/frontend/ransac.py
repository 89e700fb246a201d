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

The samples are drawn up front (numpy, seeded); the hypotheses are then taken one by one,
as v2 takes them, by compiled code (numba) that releases the GIL, so that comparisons on
two threads run on two cores.
"""

from dataclasses import dataclass

import numpy as np

from ..compiled import jit

SAMPLE_SIZE = 4
MAX_REFINEMENTS = 19
# errorFunction2's lateral noise: 3 pixels of a 640x480 Kinect with a 58 x 45 degree field of
# view, as an angle; the lateral variance is this squared times the depth (v2's model).
RASTER_COV_X = (3 * np.tan(np.radians(58.0) / 640)) ** 2
RASTER_COV_Y = (3 * np.tan(np.radians(45.0) / 480)) ** 2
# Squared distances beyond this many times the two points' largest variances are outliers
# without the full Mahalanobis test (errorFunction2's shortcut).
SHORTCUT_FACTOR = 2.0
# v2's error of a hypothesis with fewer than three inliers, and of no hypothesis yet.
NO_INLIERS_ERROR = 1e9
NO_HYPOTHESIS_ERROR = 1e6
# Jacobi sweeps at most for the 4x4 eigenproblem of the fit (it converges in about six).
JACOBI_SWEEPS = 30



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


@jit
def _pair_distance(r, source, target, sigma_depth):
    """errorFunction2 for one pair: squared Mahalanobis distance of ``r source - target``
    under ``R^T C_source R + C_target`` (v2's form), or inf beyond the shortcut bound.

    ``r`` is the transform's top 3x4 as a flat tuple. Each covariance is
    ``diag(RASTER_COV_X z, RASTER_COV_Y z, (sigma_depth z²)²)``; the symmetric 3x3 system is
    solved in closed form (adjugate over determinant).
    """
    r00, r01, r02, r03, r10, r11, r12, r13, r20, r21, r22, r23 = r
    sx, sy, z_source = source
    tx, ty, z_target = target
    x = r00 * sx + r01 * sy + r02 * z_source + r03 - tx
    y = r10 * sx + r11 * sy + r12 * z_source + r13 - ty
    z = r20 * sx + r21 * sy + r22 * z_source + r23 - z_target
    depth_source = (sigma_depth * z_source * z_source) ** 2
    depth_target = (sigma_depth * z_target * z_target) ** 2
    if x * x + y * y + z * z > SHORTCUT_FACTOR * (max(RASTER_COV_X, depth_source) + max(RASTER_COV_X, depth_target)):
        return np.inf
    cx, cy, cz = RASTER_COV_X * z_source, RASTER_COV_Y * z_source, depth_source
    s00 = cx * r00 * r00 + cy * r10 * r10 + cz * r20 * r20 + RASTER_COV_X * z_target
    s11 = cx * r01 * r01 + cy * r11 * r11 + cz * r21 * r21 + RASTER_COV_Y * z_target
    s22 = cx * r02 * r02 + cy * r12 * r12 + cz * r22 * r22 + depth_target
    s01 = cx * r00 * r01 + cy * r10 * r11 + cz * r20 * r21
    s02 = cx * r00 * r02 + cy * r10 * r12 + cz * r20 * r22
    s12 = cx * r01 * r02 + cy * r11 * r12 + cz * r21 * r22
    a00, a11, a22 = s11 * s22 - s12 * s12, s00 * s22 - s02 * s02, s00 * s11 - s01 * s01
    a01, a02, a12 = s02 * s12 - s01 * s22, s01 * s12 - s11 * s02, s01 * s02 - s00 * s12
    determinant = s00 * a00 + s01 * a01 + s02 * a02
    return (a00 * x * x + a11 * y * y + a22 * z * z + 2.0 * (a01 * x * y + a02 * x * z + a12 * y * z)) / determinant


@jit
def _top_rows(transform):
    """The transform's top 3x4, row by row, as a tuple of scalars."""
    return (transform[0, 0], transform[0, 1], transform[0, 2], transform[0, 3],
            transform[1, 0], transform[1, 1], transform[1, 2], transform[1, 3],
            transform[2, 0], transform[2, 1], transform[2, 2], transform[2, 3])


@jit
def _distances(transforms, source, target, sigma_depth):
    out = np.empty((transforms.shape[0], source.shape[0]))
    for h in range(transforms.shape[0]):
        r = _top_rows(transforms[h])
        for n in range(source.shape[0]):
            out[h, n] = _pair_distance(r, (source[n, 0], source[n, 1], source[n, 2]),
                                       (target[n, 0], target[n, 1], target[n, 2]), sigma_depth)
    return out


def mahalanobis_squared(transforms: np.ndarray, source: np.ndarray, target: np.ndarray,
                        sigma_depth: float) -> np.ndarray:
    """v2's ``errorFunction2`` ``(H, N)`` for transforms ``(H, 4, 4)`` and pairs ``(N, 3)``:
    squared Mahalanobis distances, inf for pairs beyond the shortcut."""
    return _distances(np.ascontiguousarray(transforms, dtype=np.float64), np.ascontiguousarray(source, dtype=np.float64),
                      np.ascontiguousarray(target, dtype=np.float64), float(sigma_depth))


@jit
def _first_distinct(stream, hypotheses, size):
    """Consecutive sets of ``size`` distinct values of ``stream``, each sorted (a set in v2),
    and how many sets the stream filled."""
    samples = np.empty((hypotheses, size), dtype=np.int64)
    position = 0
    for filled in range(hypotheses):
        chosen = 0
        while chosen < size:
            if position == stream.shape[0]:
                return samples, filled
            value = stream[position]
            position += 1
            slot = chosen
            while slot > 0 and samples[filled, slot - 1] > value:
                slot -= 1
            if slot > 0 and samples[filled, slot - 1] == value:
                continue
            for k in range(chosen, slot, -1):
                samples[filled, k] = samples[filled, k - 1]
            samples[filled, slot] = value
            chosen += 1
    return samples, hypotheses


def preferred_samples(count: int, hypotheses: int, rng: np.random.Generator, size: int = SAMPLE_SIZE) -> np.ndarray:
    """``(hypotheses, size)`` sets of distinct indices into ``count`` best-first matches,
    each index the smaller of two uniform draws (``sample_matches_prefer_by_distance``)."""
    if count < size:
        raise ValueError(f"cannot draw {size} distinct indices from {count}")
    stream = np.zeros(0, dtype=np.int64)
    while True:
        pairs = rng.integers(count, size=4 * hypotheses * size)
        stream = np.concatenate([stream, np.minimum(pairs[0::2], pairs[1::2])])
        samples, filled = _first_distinct(stream, hypotheses, size)
        if filled == hypotheses:
            return samples


@jit
def _largest_eigenvector(matrix):
    """Unit eigenvector of the largest eigenvalue of a symmetric 4x4 matrix (cyclic Jacobi
    rotations until the off-diagonal part vanishes; overwrites ``matrix``)."""
    vectors = np.eye(4)
    for _ in range(JACOBI_SWEEPS):
        off = 0.0
        for p in range(3):
            for q in range(p + 1, 4):
                off += matrix[p, q] * matrix[p, q]
        if off == 0.0:
            break
        for p in range(3):
            for q in range(p + 1, 4):
                if matrix[p, q] == 0.0:
                    continue
                theta = (matrix[q, q] - matrix[p, p]) / (2.0 * matrix[p, q])
                t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + np.sqrt(theta * theta + 1.0))
                c = 1.0 / np.sqrt(t * t + 1.0)
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
    best = 0
    for k in range(1, 4):
        if matrix[k, k] > matrix[best, best]:
            best = k
    return vectors[:, best]


@jit
def _fit(source, target, weights, members):
    """The rigid transform minimising the weighted squared residuals of the ``members``:
    weighted centroids, then the rotation as the quaternion that maximises the correlation
    of the centred points (Horn 1987; the same optimum as the SVD fit, always proper)."""
    total = 0.0
    mean_source, mean_target = np.zeros(3), np.zeros(3)
    for n in members:
        total += weights[n]
        for i in range(3):
            mean_source[i] += weights[n] * source[n, i]
            mean_target[i] += weights[n] * target[n, i]
    mean_source /= total
    mean_target /= total
    m = np.zeros((3, 3))  # m[a, b] = sum w (source_a - mean) (target_b - mean)
    for n in members:
        w = weights[n] / total
        for a in range(3):
            for b in range(3):
                m[a, b] += w * (source[n, a] - mean_source[a]) * (target[n, b] - mean_target[b])
    horn = np.empty((4, 4))
    horn[0, 0] = m[0, 0] + m[1, 1] + m[2, 2]
    horn[1, 1] = m[0, 0] - m[1, 1] - m[2, 2]
    horn[2, 2] = m[1, 1] - m[0, 0] - m[2, 2]
    horn[3, 3] = m[2, 2] - m[0, 0] - m[1, 1]
    horn[0, 1] = horn[1, 0] = m[1, 2] - m[2, 1]
    horn[0, 2] = horn[2, 0] = m[2, 0] - m[0, 2]
    horn[0, 3] = horn[3, 0] = m[0, 1] - m[1, 0]
    horn[1, 2] = horn[2, 1] = m[0, 1] + m[1, 0]
    horn[1, 3] = horn[3, 1] = m[2, 0] + m[0, 2]
    horn[2, 3] = horn[3, 2] = m[1, 2] + m[2, 1]
    w, x, y, z = _largest_eigenvector(horn)
    transform = np.eye(4)
    transform[0, 0], transform[0, 1], transform[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    transform[1, 0], transform[1, 1], transform[1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    transform[2, 0], transform[2, 1], transform[2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    for i in range(3):
        transform[i, 3] = mean_target[i] - (transform[i, 0] * mean_source[0] + transform[i, 1] * mean_source[1]
                                            + transform[i, 2] * mean_source[2])
    return transform


@jit
def _inliers(transform, source, target, sigma_depth, threshold):
    """computeInliersAndError: inlier indices and their RMS Mahalanobis distance
    (NO_INLIERS_ERROR below three inliers)."""
    members = np.empty(source.shape[0], dtype=np.int64)
    count, total = 0, 0.0
    r = _top_rows(transform)
    for n in range(source.shape[0]):
        distance = _pair_distance(r, (source[n, 0], source[n, 1], source[n, 2]),
                                  (target[n, 0], target[n, 1], target[n, 2]), sigma_depth)
        if distance <= threshold:
            members[count] = n
            count += 1
            total += distance
    error = np.sqrt(total / count) if count >= 3 else NO_INLIERS_ERROR
    return members[:count], error


@jit
def _refine(sample, source, target, weights, sigma_depth, max_distance, min_inliers):
    """One hypothesis as v2 refines it: (transform, inlier indices, RMS error), no inliers
    when it never reached ``min_inliers`` within ``max_distance``."""
    best_transform = np.eye(4)
    best_members = sample[:0]
    best_error = NO_HYPOTHESIS_ERROR
    members = sample
    for _ in range(MAX_REFINEMENTS):
        transform = _fit(source, target, weights, members)
        members, error = _inliers(transform, source, target, sigma_depth, max_distance * max_distance)
        if len(members) < min_inliers or error > max_distance:
            break
        if len(members) < len(best_members) or error > best_error:
            break
        unchanged = len(members) == len(best_members)
        best_transform, best_members, best_error = transform, members, error
        if unchanged:
            break
    return best_transform, best_members, best_error


@jit
def _search(samples, source, target, iterations, max_distance, min_inliers, sigma_depth):
    """v2's hypothesis loop over ``samples``: (transform, inlier indices, RMS error, number
    of hypotheses that reached ``min_inliers``)."""
    count = source.shape[0]
    weights = 1.0 / (source[:, 2] * target[:, 2])
    best_transform = np.eye(4)
    best_members = samples[0, :0]
    best_error = NO_HYPOTHESIS_ERROR
    valid, drawn = 0, 0
    while drawn < iterations:
        transform, members, error = _refine(samples[drawn], source, target, weights, sigma_depth, max_distance,
                                            min_inliers)
        drawn += 1
        inliers = len(members)
        if inliers == 0:
            continue
        valid += 1
        if error <= best_error and inliers >= len(best_members) and inliers >= min_inliers:
            best_transform, best_members, best_error = transform, members, error
            drawn += 10 * int(inliers > 0.5 * count) + 10 * int(inliers > 0.75 * count)
            if inliers > 0.8 * count:
                break
    return best_transform, best_members, best_error, valid


def ransac_rigid(source: np.ndarray, target: np.ndarray, *, iterations: int, max_mahalanobis: float,
                 min_inliers: int, sigma_depth: float, rng: np.random.Generator) -> RansacResult | None:
    """The rigid transform best supported by correspondences ``source[i] <-> target[i]``,
    ordered best match first, or None when it has fewer than ``min_inliers`` inliers.

    ``min_inliers`` is lowered to three quarters of the correspondences when that is less (v2).
    """
    count = len(source)
    if count < SAMPLE_SIZE:
        return None
    source = np.ascontiguousarray(source, dtype=np.float64)
    target = np.ascontiguousarray(target, dtype=np.float64)
    min_inliers = min(min_inliers, int(0.75 * count))
    samples = preferred_samples(count, iterations, rng)
    transform, members, error, valid = _search(samples, source, target, iterations, float(max_mahalanobis),
                                               min_inliers, float(sigma_depth))
    if valid == 0:
        identity = np.eye(4)
        members, error = _inliers(identity, source, target, float(sigma_depth), float(max_mahalanobis) ** 2)
        if not (len(members) > min_inliers and error < max_mahalanobis):
            return None
        transform = identity
    if len(members) < max(min_inliers, 3):
        return None
    mask = np.zeros(count, dtype=bool)
    mask[members] = True
    return RansacResult(transform, mask, float(error))
