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
# Jacobi rotation angles beyond which theta² + 1 rounds to theta² (2^27), and beyond which
# theta² overflows (2^512): see jacobi_rotation.
LARGE_THETA = 2.0**27
LARGE_THETA_OVERFLOWS = 2.0**512
# _settled's margins: diagonal gaps at least SETTLED_GAP times every off-diagonal entry (so
# every rotation has |theta| >= 2^27 and a cosine of exactly 1), diagonal entries at most
# SETTLED_SPREAD times the least gap, and changes below SETTLED_ROUNDING times the entry they
# would change (under a quarter of its unit in the last place).
SETTLED_GAP = 2.0**30
SETTLED_SPREAD = 2.0**40
SETTLED_ROUNDING = 2.0**-56
# Rows of pair_terms: source x, y, z; target x, y, z; the source's covariance diagonal; the
# target's; the shortcut bound.
PAIR_TERMS = 13


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
def pair_terms(source, target, sigma_depth):
    """What errorFunction2 computes of each pair alone, once per RANSAC run instead of once per
    hypothesis: ``(PAIR_TERMS, N)`` rows (see :data:`PAIR_TERMS`), contiguous so that the
    distance loop runs on vectors.

    Each covariance is ``diag(RASTER_COV_X z, RASTER_COV_Y z, (sigma_depth z²)²)``; the shortcut
    bound is SHORTCUT_FACTOR times the two points' largest variances (with v2's
    RASTER_COV_X for both lateral terms).
    """
    terms = np.empty((PAIR_TERMS, source.shape[0]))
    for n in range(source.shape[0]):
        z_source, z_target = source[n, 2], target[n, 2]
        depth_source = (sigma_depth * z_source * z_source) ** 2
        depth_target = (sigma_depth * z_target * z_target) ** 2
        terms[0, n], terms[1, n], terms[2, n] = source[n, 0], source[n, 1], z_source
        terms[3, n], terms[4, n], terms[5, n] = target[n, 0], target[n, 1], z_target
        terms[6, n], terms[7, n], terms[8, n] = RASTER_COV_X * z_source, RASTER_COV_Y * z_source, depth_source
        terms[9, n], terms[10, n], terms[11, n] = RASTER_COV_X * z_target, RASTER_COV_Y * z_target, depth_target
        terms[12, n] = SHORTCUT_FACTOR * (max(RASTER_COV_X, depth_source) + max(RASTER_COV_X, depth_target))
    return terms


@jit
def _distances_into(r, terms, out):
    """errorFunction2 for every pair, into ``out``: squared Mahalanobis distance of
    ``r source - target`` under ``R^T C_source R + C_target`` (v2's form), or inf beyond the
    shortcut bound.

    ``r`` is the transform's top 3x4 as a flat tuple. The symmetric 3x3 system is solved in
    closed form (adjugate over determinant). Every pair is computed and the shortcut applied
    as a choice, so that the loop has no branch and runs on vectors; each lane does the same
    operations in the same order as one pair alone, so the distances are the same to the bit.
    """
    r00, r01, r02, r03, r10, r11, r12, r13, r20, r21, r22, r23 = r
    sx, sy, z_source, tx, ty, z_target = terms[0], terms[1], terms[2], terms[3], terms[4], terms[5]
    cx, cy, cz, target_x, target_y, target_z, bound = (
        terms[6],
        terms[7],
        terms[8],
        terms[9],
        terms[10],
        terms[11],
        terms[12],
    )
    for n in range(out.shape[0]):
        x = r00 * sx[n] + r01 * sy[n] + r02 * z_source[n] + r03 - tx[n]
        y = r10 * sx[n] + r11 * sy[n] + r12 * z_source[n] + r13 - ty[n]
        z = r20 * sx[n] + r21 * sy[n] + r22 * z_source[n] + r23 - z_target[n]
        s00 = cx[n] * r00 * r00 + cy[n] * r10 * r10 + cz[n] * r20 * r20 + target_x[n]
        s11 = cx[n] * r01 * r01 + cy[n] * r11 * r11 + cz[n] * r21 * r21 + target_y[n]
        s22 = cx[n] * r02 * r02 + cy[n] * r12 * r12 + cz[n] * r22 * r22 + target_z[n]
        s01 = cx[n] * r00 * r01 + cy[n] * r10 * r11 + cz[n] * r20 * r21
        s02 = cx[n] * r00 * r02 + cy[n] * r10 * r12 + cz[n] * r20 * r22
        s12 = cx[n] * r01 * r02 + cy[n] * r11 * r12 + cz[n] * r21 * r22
        a00, a11, a22 = s11 * s22 - s12 * s12, s00 * s22 - s02 * s02, s00 * s11 - s01 * s01
        a01, a02, a12 = s02 * s12 - s01 * s22, s01 * s12 - s11 * s02, s01 * s02 - s00 * s12
        determinant = s00 * a00 + s01 * a01 + s02 * a02
        distance = (
            a00 * x * x + a11 * y * y + a22 * z * z + 2.0 * (a01 * x * y + a02 * x * z + a12 * y * z)
        ) / determinant
        out[n] = np.inf if x * x + y * y + z * z > bound[n] else distance


@jit
def _top_rows(transform):
    """The transform's top 3x4, row by row, as a tuple of scalars."""
    return (
        transform[0, 0],
        transform[0, 1],
        transform[0, 2],
        transform[0, 3],
        transform[1, 0],
        transform[1, 1],
        transform[1, 2],
        transform[1, 3],
        transform[2, 0],
        transform[2, 1],
        transform[2, 2],
        transform[2, 3],
    )


@jit
def _distances(transforms, terms):
    out = np.empty((transforms.shape[0], terms.shape[1]))
    for h in range(transforms.shape[0]):
        _distances_into(_top_rows(transforms[h]), terms, out[h])
    return out


def mahalanobis_squared(
    transforms: np.ndarray, source: np.ndarray, target: np.ndarray, sigma_depth: float
) -> np.ndarray:
    """v2's ``errorFunction2`` ``(H, N)`` for transforms ``(H, 4, 4)`` and pairs ``(N, 3)``:
    squared Mahalanobis distances, inf for pairs beyond the shortcut."""
    terms = pair_terms(np.asarray(source, dtype=np.float64), np.asarray(target, dtype=np.float64), float(sigma_depth))
    return _distances(np.ascontiguousarray(transforms, dtype=np.float64), terms)


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
def _moved(old, new):
    """Whether 4x4 ``new`` differs from ``old`` in any bit (NaN always counts as moved)."""
    for i in range(4):
        for j in range(4):
            if not (old[i, j] == new[i, j] and np.copysign(1.0, old[i, j]) == np.copysign(1.0, new[i, j])):
                return True
    return False


@jit
def jacobi_rotation(theta):
    """The tangent ``t`` and cosine ``c`` of the Jacobi rotation for ``theta = (a_qq - a_pp) /
    (2 a_pq)``: ``t = sign(theta) / (|theta| + sqrt(theta² + 1))``, ``c = 1 / sqrt(t² + 1)``,
    the same to the bit, without the square roots where they cannot change the result.

    Most rotations of a solve come after the matrix is diagonal to the last bit, to drive the
    off-diagonal part to zero: there ``|theta|`` is huge. From 2^27, ``theta² + 1`` rounds to
    ``theta²``, whose square root is ``|theta|`` exactly (it is so for every square that
    neither overflows nor underflows), so ``t = sign / (2 |theta|)``; ``t²`` is then at most
    2^-56, so ``t² + 1`` rounds to 1 and ``c`` is 1. From 2^512 (or an infinite ``theta``),
    ``theta²`` overflows to inf and ``t`` is a zero of the sign of ``theta``. Between 2^511
    and 2^512 the square may or may not overflow, and the formula is taken as it is.
    """
    sign = 1.0 if theta >= 0 else -1.0
    size = abs(theta)
    if size >= LARGE_THETA_OVERFLOWS:
        return sign * 0.0, 1.0
    if LARGE_THETA <= size < LARGE_THETA_OVERFLOWS / 2:
        return sign / (size + size), 1.0
    t = sign / (size + np.sqrt(theta * theta + 1.0))
    return t, 1.0 / np.sqrt(t * t + 1.0)


@jit
def _settled(matrix, vectors):
    """Whether no rotation to come can change a bit of ``matrix``'s diagonal or of ``vectors``,
    which are all the solve returns: the rotations that remain would only shrink the
    off-diagonal part towards zero.

    The rotations read the upper triangle (at most ``u``) for their angles; the rounding
    left in the lower triangle (at most ``l``) stays near the last bits of the diagonal. With
    diagonal gaps at least ``g`` >= SETTLED_GAP ``2u``, every rotation has |theta| >= 2^27:
    its cosine is exactly 1 and |t| <= ``t = 2u / g``. It then moves a vector entry by at
    most ``t``, and a diagonal entry, in each of its two roundings, by at most ``t (e + t d)``
    (``d`` the largest diagonal entry, ``e`` the largest off-diagonal one): below
    SETTLED_ROUNDING times the entry, the change rounds back to it. The diagonal being
    unchanged, the gaps stay. Over all JACOBI_SWEEPS, an upper entry grows by at most
    ``180 t e`` (the one a rotation zeroes keeps a few roundings of ``t d``, below ``u`` while
    d <= SETTLED_SPREAD g), a lower one by at most ``360 t d``: ``e`` bounds them with ``2u``
    and ``2l + 1024 t d``. NaN and infinities never settle.
    """
    for p in range(4):
        for q in range(4):
            if not np.isfinite(matrix[p, q]):
                return False
    upper, lower, gap, largest_diagonal = 0.0, 0.0, np.inf, 0.0
    for p in range(4):
        largest_diagonal = max(largest_diagonal, abs(matrix[p, p]))
        for q in range(p + 1, 4):
            upper = max(upper, abs(matrix[p, q]))
            lower = max(lower, abs(matrix[q, p]))
            gap = min(gap, abs(matrix[q, q] - matrix[p, p]))
    upper *= 2.0
    if not (gap >= SETTLED_GAP * upper and largest_diagonal <= SETTLED_SPREAD * gap):
        return False
    t = upper / gap
    off = max(upper, 2.0 * lower + 1024.0 * t * largest_diagonal)
    if not 360.0 * off <= gap:  # upper entries grow by at most 180 t e <= u/2
        return False
    for k in range(4):
        if not 2.0 * t * (off + t * largest_diagonal) < SETTLED_ROUNDING * abs(matrix[k, k]):
            return False
        for j in range(4):
            if not 2.0 * t < SETTLED_ROUNDING * abs(vectors[k, j]):
                return False
    return True


@jit
def _largest_eigenvector(matrix):
    """Unit eigenvector of the largest eigenvalue of a symmetric 4x4 matrix (cyclic Jacobi
    rotations until the off-diagonal part vanishes; overwrites ``matrix``).

    The off-diagonal part often stops short of zero, some 1e-155, where each rotation's angle
    overflows to zero and changes nothing; a sweep that left the matrix and the vectors the
    same to the bit would leave them so every time after, so the rotations end there (with
    the result of running all JACOBI_SWEEPS, in a fraction of the time: those sweeps also
    compute on subnormal numbers, at a hundred times the cost of normal ones). They end
    sooner still, with the same result, once they can no longer change what is returned
    (:func:`_settled`): two thirds of the rotations of a RANSAC run came after that.
    """
    vectors = np.eye(4)
    before = np.empty((2, 4, 4))
    for _ in range(JACOBI_SWEEPS):
        off = 0.0
        for p in range(3):
            for q in range(p + 1, 4):
                off += matrix[p, q] * matrix[p, q]
        if off == 0.0 or _settled(matrix, vectors):
            break
        before[0], before[1] = matrix, vectors
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
        if not _moved(before[0], matrix) and not _moved(before[1], vectors):
            break
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
    source_x = source_y = source_z = target_x = target_y = target_z = 0.0
    for n in members:
        total += weights[n]
        source_x += weights[n] * source[n, 0]
        source_y += weights[n] * source[n, 1]
        source_z += weights[n] * source[n, 2]
        target_x += weights[n] * target[n, 0]
        target_y += weights[n] * target[n, 1]
        target_z += weights[n] * target[n, 2]
    source_x, source_y, source_z = source_x / total, source_y / total, source_z / total
    target_x, target_y, target_z = target_x / total, target_y / total, target_z / total
    # m_ab = sum w (source_a - mean) (target_b - mean), in scalars that stay in registers
    m00 = m01 = m02 = m10 = m11 = m12 = m20 = m21 = m22 = 0.0
    for n in members:
        w = weights[n] / total
        a0, a1, a2 = source[n, 0] - source_x, source[n, 1] - source_y, source[n, 2] - source_z
        b0, b1, b2 = target[n, 0] - target_x, target[n, 1] - target_y, target[n, 2] - target_z
        m00 += w * a0 * b0
        m01 += w * a0 * b1
        m02 += w * a0 * b2
        m10 += w * a1 * b0
        m11 += w * a1 * b1
        m12 += w * a1 * b2
        m20 += w * a2 * b0
        m21 += w * a2 * b1
        m22 += w * a2 * b2
    horn = np.empty((4, 4))
    horn[0, 0] = m00 + m11 + m22
    horn[1, 1] = m00 - m11 - m22
    horn[2, 2] = m11 - m00 - m22
    horn[3, 3] = m22 - m00 - m11
    horn[0, 1] = horn[1, 0] = m12 - m21
    horn[0, 2] = horn[2, 0] = m20 - m02
    horn[0, 3] = horn[3, 0] = m01 - m10
    horn[1, 2] = horn[2, 1] = m01 + m10
    horn[1, 3] = horn[3, 1] = m20 + m02
    horn[2, 3] = horn[3, 2] = m12 + m21
    w, x, y, z = _largest_eigenvector(horn)
    transform = np.eye(4)
    transform[0, 0], transform[0, 1], transform[0, 2] = (
        1 - 2 * (y * y + z * z),
        2 * (x * y - w * z),
        2 * (x * z + w * y),
    )
    transform[1, 0], transform[1, 1], transform[1, 2] = (
        2 * (x * y + w * z),
        1 - 2 * (x * x + z * z),
        2 * (y * z - w * x),
    )
    transform[2, 0], transform[2, 1], transform[2, 2] = (
        2 * (x * z - w * y),
        2 * (y * z + w * x),
        1 - 2 * (x * x + y * y),
    )
    for i, target_mean in enumerate((target_x, target_y, target_z)):
        transform[i, 3] = target_mean - (
            transform[i, 0] * source_x + transform[i, 1] * source_y + transform[i, 2] * source_z
        )
    return transform


@jit
def _inliers(transform, terms, threshold, distances):
    """computeInliersAndError: inlier indices and their RMS Mahalanobis distance
    (NO_INLIERS_ERROR below three inliers); ``distances`` is scratch space, one per pair."""
    _distances_into(_top_rows(transform), terms, distances)
    return _within(distances, threshold)


@jit
def _count_within(distances, threshold):
    """How many ``distances`` are at most ``threshold`` (a loop without branches)."""
    count = 0
    for n in range(distances.shape[0]):
        count += distances[n] <= threshold
    return count


@jit
def _within(distances, threshold):
    """The indices of the ``distances`` at most ``threshold`` and their RMS (NO_INLIERS_ERROR
    below three)."""
    members = np.empty(distances.shape[0], dtype=np.int64)
    count, total = 0, 0.0
    for n in range(distances.shape[0]):
        if distances[n] <= threshold:
            members[count] = n
            count += 1
            total += distances[n]
    error = np.sqrt(total / count) if count >= 3 else NO_INLIERS_ERROR
    return members[:count], error


@jit
def _refine(sample, source, target, weights, terms, distances, max_distance, min_inliers):
    """One hypothesis as v2 refines it: (transform, inlier indices, RMS error), no inliers
    when it never reached ``min_inliers`` within ``max_distance``."""
    best_transform = np.eye(4)
    best_members = sample[:0]
    best_error = NO_HYPOTHESIS_ERROR
    members = sample
    threshold = max_distance * max_distance
    for _ in range(MAX_REFINEMENTS):
        transform = _fit(source, target, weights, members)
        _distances_into(_top_rows(transform), terms, distances)
        # Most hypotheses end here, on their count alone: their inliers need not be listed.
        if _count_within(distances, threshold) < min_inliers:
            break
        members, error = _within(distances, threshold)
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
def _search(samples, source, target, terms, iterations, max_distance, min_inliers):
    """v2's hypothesis loop over ``samples``: (transform, inlier indices, RMS error, number
    of hypotheses that reached ``min_inliers``)."""
    count = source.shape[0]
    weights = 1.0 / (source[:, 2] * target[:, 2])
    distances = np.empty(count)
    best_transform = np.eye(4)
    best_members = samples[0, :0]
    best_error = NO_HYPOTHESIS_ERROR
    valid, drawn = 0, 0
    while drawn < iterations:
        transform, members, error = _refine(
            samples[drawn], source, target, weights, terms, distances, max_distance, min_inliers
        )
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


def ransac_rigid(
    source: np.ndarray,
    target: np.ndarray,
    *,
    iterations: int,
    max_mahalanobis: float,
    min_inliers: int,
    sigma_depth: float,
    rng: np.random.Generator,
) -> RansacResult | None:
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
    terms = pair_terms(source, target, float(sigma_depth))
    transform, members, error, valid = _search(
        samples, source, target, terms, iterations, float(max_mahalanobis), min_inliers
    )
    if valid == 0:
        identity = np.eye(4)
        members, error = _inliers(identity, terms, float(max_mahalanobis) ** 2, np.empty(count))
        if not (len(members) > min_inliers and error < max_mahalanobis):
            return None
        transform = identity
    if len(members) < max(min_inliers, 3):
        return None
    mask = np.zeros(count, dtype=bool)
    mask[members] = True
    return RansacResult(transform, mask, float(error))
