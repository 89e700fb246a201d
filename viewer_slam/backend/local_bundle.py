"""Bundle adjustment of one frame against fixed key frames, solved as g2o solves it for RTAB-Map.

This is the problem RTAB-Map's frame-to-map odometry solves after each registration
(``OdometryF2M::computeTransform`` calling ``OptimizerG2O::optimizeBA`` with a negative
root): the new frame's pose and the 3D points it registered on are free, the key frames
that saw those points are fixed, each observation is a reprojection edge with the pixel
variance as noise under a Huber kernel, and a link (g2o's ``EdgeSBACam``) ties the frame to
the last key frame with the registration's own variance on the relative pose's translation
and quaternion vector part. An observation with depth is a stereo edge on a fake baseline
(RTAB-Map's g2o/Baseline for RGB-D): its third coordinate is ``u - fx * baseline / depth``,
so the depth is weighed in pixels too; one without depth is a plain projection.

The solver is g2o's Levenberg-Marquardt (``OptimizationAlgorithmLevenberg``) on the Schur
complement of the points (``BlockSolver_6_3``, points marginalised), vectorised over the
observations, the normal equations summed in compiled code: the camera moves by
``t += dt`` and ``R = R q(dv)`` with ``q(dv)`` the unit
quaternion of vector part ``dv`` (g2o's ``SBACam::update``); the first damping is 1e-5 times
the largest diagonal entry of the Hessian; a step is kept when it lowers the robust chi2, the
damping then scaled by ``max(1/3, min(2/3, 1 - (2 rho - 1)^3))``, and otherwise undone with
the damping multiplied by 2, 4, 8, ... for at most 10 trials, after which the pass ends; the
Huber kernel weighs each edge's information by ``rho'(chi2)``. As in ``optimizeBA`` there are
two passes, 5 iterations and then Optimizer/Iterations; after each, every edge whose chi2
(squared error over the pixel variance) exceeds the kernel's delta leaves the optimisation
and its point counts as an outlier.
"""

from dataclasses import dataclass

import numba
import numpy as np

from ..geometry.se3 import invert, make_pose, transform_points

FIRST_PASS_ITERATIONS = 5        # OptimizerG2O::optimizeBA's first, robust-only pass
FREE_FRAME = -1                  # frame id of the observations made by the adjusted frame
LAMBDA_INIT_FACTOR = 1e-5        # g2o's tau: first damping over the largest Hessian diagonal entry
MAX_TRIALS_AFTER_FAILURE = 10    # g2o's maxTrialsAfterFailure
GOOD_STEP_LOWER_SCALE = 1.0 / 3.0
GOOD_STEP_UPPER_SCALE = 2.0 / 3.0
SCALE_EPSILON = 1e-3             # g2o adds it to the predicted decrease "to make sure it's non-zero"
LINK_VARIANCE_FLOOR = 1e-12


@dataclass
class Observations:
    """Where the points were seen: ``point`` (M,) indices into the points, ``frame`` (M,)
    key-frame ids (FREE_FRAME for the adjusted frame), ``pixels`` (M, 2) undistorted pixel
    coordinates and ``depth`` (M,) the measured depth (NaN or 0 where there is none)."""

    point: np.ndarray
    frame: np.ndarray
    pixels: np.ndarray
    depth: np.ndarray

    def __len__(self) -> int:
        return len(self.point)

    @property
    def stereo(self) -> np.ndarray:
        return np.nan_to_num(self.depth) > 0


@dataclass
class Link:
    """The adjusted frame's registration against key frame ``frame``: ``relative`` is
    ``T_frame^-1 T_adjusted`` and ``variance`` that of every axis (m², rad²)."""

    frame: int
    relative: np.ndarray
    variance: float


@dataclass
class BundleSettings:
    """RTAB-Map's g2o/PixelVariance, g2o/RobustKernelDelta (0: no kernel, one pass),
    g2o/Baseline and Optimizer/Iterations."""

    pixel_variance: float = 1.0
    kernel_delta: float = 8.0
    baseline: float = 0.075
    iterations: int = 20


@dataclass
class BundleResult:
    """The adjusted frame's pose (``T_world_camera``), the points after adjustment and which
    points had an observation dropped."""

    pose: np.ndarray
    points: np.ndarray
    outliers: np.ndarray


def measurements(observations: Observations, fx: float, baseline: float) -> np.ndarray:
    """(M, 3) measured (u, v, u - fx b / depth); the third is 0 for an edge without depth."""
    stereo = observations.stereo
    right = np.zeros(len(observations))
    right[stereo] = observations.pixels[stereo, 0] - fx * baseline / observations.depth[stereo]
    return np.column_stack([observations.pixels, right])


def reprojection_errors(in_camera: np.ndarray, measured: np.ndarray, stereo: np.ndarray, K: np.ndarray,
                        baseline: float) -> np.ndarray:
    """(M, 3) predicted minus measured (u, v, u_right) of camera-frame points; the third is 0
    for an edge without depth."""
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    x, y, z = in_camera.T
    with np.errstate(divide="ignore", invalid="ignore"):
        u = fx * x / z + cx
        predicted = np.stack([u, fy * y / z + cy, u - fx * baseline / z], axis=1)
    error = predicted - measured
    error[~stereo, 2] = 0.0
    return error


def edge_chi2(pose_of: dict[int, np.ndarray], points: np.ndarray, observations: Observations,
              K: np.ndarray, baseline: float, pixel_variance: float) -> np.ndarray:
    """Squared reprojection error of each observation over the pixel variance (g2o's
    ``edge->chi2()``): (u, v, u - fx b / z) for a stereo edge, (u, v) for a mono one."""
    in_camera = np.empty((len(observations), 3))
    for frame in np.unique(observations.frame):
        rows = observations.frame == frame
        in_camera[rows] = transform_points(invert(pose_of[frame]), points[observations.point[rows]])
    error = reprojection_errors(in_camera, measurements(observations, K[0, 0], baseline), observations.stereo,
                                K, baseline)
    return (error ** 2).sum(axis=1) / pixel_variance


def huber(chi2: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """g2o's RobustKernelHuber on chi2: the robust cost rho and its derivative rho' (the
    weight of the edge's information); no kernel when ``delta`` is 0."""
    if delta <= 0:
        return chi2, np.ones_like(chi2)
    root = np.sqrt(chi2)
    inside = chi2 <= delta ** 2
    with np.errstate(divide="ignore"):
        return np.where(inside, chi2, 2 * delta * root - delta ** 2), np.where(inside, 1.0, delta / root)


def quaternion_vector_rotation(vector: np.ndarray) -> np.ndarray:
    """Rotation of the unit quaternion with vector part ``vector`` and a non-negative scalar
    part (identity when the vector is not shorter than 1), as g2o's SBACam::update builds it."""
    squared = vector @ vector
    if squared >= 1.0:
        return np.eye(3)
    x, y, z = vector
    w = np.sqrt(1.0 - squared)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def updated_pose(pose: np.ndarray, step: np.ndarray) -> np.ndarray:
    """``T_world_camera`` moved by g2o's camera increment: translation added in the world
    frame, rotation multiplied on the right by the quaternion of vector part ``step[3:]``."""
    return make_pose(pose[:3, :3] @ quaternion_vector_rotation(step[3:]), pose[:3, 3] + step[:3])


def quaternion_vector(rotation: np.ndarray) -> np.ndarray:
    """Vector part of the unit quaternion of ``rotation`` taken with a non-negative scalar part."""
    w = np.sqrt(max(0.0, 1.0 + np.trace(rotation))) / 2.0
    if w > 1e-6:
        return np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0],
                         rotation[1, 0] - rotation[0, 1]]) / (4.0 * w)
    axis_squared = np.clip((np.diag(rotation) + 1.0) / 2.0, 0.0, None)
    axis = np.sqrt(axis_squared)
    largest = int(np.argmax(axis))
    signs = np.sign((rotation[largest] + rotation[:, largest]) / 2.0)
    signs[largest] = 1.0
    return axis * signs


class LinkEdge:
    """g2o's EdgeSBACam from a fixed key frame to the adjusted frame: error (translation,
    quaternion vector part) of ``measured^-1 T_key^-1 T_adjusted``, information 1/variance."""

    def __init__(self, key_pose: np.ndarray, link: Link):
        self.to_measured = invert(link.relative) @ invert(key_pose)
        self.information = 1.0 / max(link.variance, LINK_VARIANCE_FLOOR)

    def error(self, pose: np.ndarray) -> np.ndarray:
        delta = self.to_measured @ pose
        return np.concatenate([delta[:3, 3], quaternion_vector(delta[:3, :3])])

    def chi2(self, pose: np.ndarray) -> float:
        error = self.error(pose)
        return float(self.information * error @ error)

    def jacobian(self, pose: np.ndarray) -> np.ndarray:
        """d error / d camera increment: the translation turns with the measured-to-key rotation;
        the quaternion (w, a) of the relative rotation times (1, dv) has vector part a + w dv + a x dv."""
        delta = self.to_measured @ pose
        vector = quaternion_vector(delta[:3, :3])
        scalar = np.sqrt(max(0.0, 1.0 - vector @ vector))
        jacobian = np.zeros((6, 6))
        jacobian[:3, :3] = self.to_measured[:3, :3]
        jacobian[3:, 3:] = scalar * np.eye(3) + skew(vector[None])[0]
        return jacobian


@dataclass
class _Evaluation:
    """The edges at one estimate: camera-frame points, reprojection errors, chi2, robust cost."""

    pose: np.ndarray
    points: np.ndarray
    in_camera: np.ndarray
    error: np.ndarray
    chi2: np.ndarray
    cost: float


class _Problem:
    """The edges of one adjustment with what stays fixed across iterations: the measured
    coordinates, the fixed key frames' world-to-camera transforms and the edges sorted by
    point (which fixes the order of the per-point sums)."""

    def __init__(self, observations: Observations, held: dict[int, np.ndarray], link: Link | None,
                 K: np.ndarray, settings: BundleSettings, point_count: int):
        order = np.argsort(observations.point, kind="stable")
        self.K, self.settings, self.point_count = K, settings, point_count
        self.point = observations.point[order]
        self.free = observations.frame[order] == FREE_FRAME
        self.stereo = observations.stereo[order]
        self.measured = measurements(observations, K[0, 0], settings.baseline)[order]
        frames = observations.frame[order]
        self.free_rows, self.held_rows = np.flatnonzero(self.free), np.flatnonzero(~self.free)
        held_frames, held_index = np.unique(frames[self.held_rows], return_inverse=True)
        self.held_to_camera = np.stack([invert(held[frame]) for frame in held_frames])[held_index.ravel()]
        self.link = LinkEdge(held[link.frame], link) if link is not None else None
        self.free_points, self.held_points = self.point[self.free_rows], self.point[self.held_rows]

    def in_camera(self, pose: np.ndarray, points: np.ndarray) -> np.ndarray:
        result = np.empty((len(self.point), 3))
        result[self.held_rows] = (np.einsum("mij,mj->mi", self.held_to_camera[:, :3, :3], points[self.held_points])
                                  + self.held_to_camera[:, :3, 3])
        result[self.free_rows] = (points[self.free_points] - pose[:3, 3]) @ pose[:3, :3]
        return result

    def chi2(self, pose: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Each edge's chi2 (in the problem's edge order)."""
        return self.evaluate(pose, points, np.ones(len(self.point), bool)).chi2

    def evaluate(self, pose: np.ndarray, points: np.ndarray, kept: np.ndarray) -> "_Evaluation":
        """The edges at ``pose`` and ``points``, and g2o's activeRobustChi2 of the kept ones
        (their Huber costs) plus the link's chi2."""
        in_camera = self.in_camera(pose, points)
        error = reprojection_errors(in_camera, self.measured, self.stereo, self.K, self.settings.baseline)
        chi2 = np.einsum("mk,mk->m", error, error) / self.settings.pixel_variance
        cost = huber(chi2[kept], self.settings.kernel_delta)[0].sum()
        cost += self.link.chi2(pose) if self.link is not None else 0.0
        return _Evaluation(pose, points, in_camera, error, chi2, float(cost))

    def normal_equations(self, at: "_Evaluation", kept: np.ndarray):
        """The Gauss-Newton system of the kept edges in blocks: camera (6x6, 6), per point
        (N, 3, 3) and (N, 3), and camera-point (N, 6, 3); b is minus the gradient."""
        settings, pose = self.settings, at.pose
        weight = np.where(kept, huber(at.chi2, settings.kernel_delta)[1], 0.0) / settings.pixel_variance
        world_to_camera = np.empty((len(self.point), 3, 3))
        world_to_camera[self.held_rows] = self.held_to_camera[:, :3, :3]
        world_to_camera[self.free_rows] = pose[:3, :3].T
        system = (np.zeros((6, 6)), np.zeros(6), np.zeros((self.point_count, 3, 3)), np.zeros((self.point_count, 3)),
                  np.zeros((self.point_count, 6, 3)))
        _accumulate_normal_equations(at.in_camera, at.error, weight, self.stereo, self.free, self.point,
                                     world_to_camera, self.K[0, 0], self.K[1, 1], settings.baseline, *system)
        hessian_camera, gradient_camera = system[0], system[1]
        if self.link is not None:
            jacobian = self.link.jacobian(pose)
            hessian_camera += self.link.information * jacobian.T @ jacobian
            gradient_camera -= self.link.information * jacobian.T @ self.link.error(pose)
        return system


@numba.njit(cache=True, nogil=True)
def _accumulate_normal_equations(in_camera, error, weight, stereo, free, point, world_to_camera, fx, fy, baseline,
                                 hessian_camera, gradient_camera, hessian_points, gradient_points, coupling):
    """Adds each edge's weighted J^T J and -J^T e to the blocks, compiled: the per-edge 3x3
    and 3x6 products are too small for NumPy to run them at speed. J is the projection's
    Jacobian (u, v and, with depth, u_right) times d(camera-frame point) / d(point) = the
    edge camera's world-to-camera rotation and, for the adjusted frame, / d(t, dv) =
    (-R^T, 2 [p]x) for g2o's camera increment."""
    projection = np.zeros((3, 3))
    point_jacobian = np.empty((3, 3))
    camera_jacobian = np.empty((3, 6))
    for m in range(len(point)):
        w = weight[m]
        if w == 0.0:
            continue
        x, y, z = in_camera[m, 0], in_camera[m, 1], in_camera[m, 2]
        inverse_z = 1.0 / z
        projection[0, 0] = fx * inverse_z
        projection[0, 2] = -fx * x * inverse_z ** 2
        projection[1, 1] = fy * inverse_z
        projection[1, 2] = -fy * y * inverse_z ** 2
        rows = 3 if stereo[m] else 2
        projection[2, 0] = fx * inverse_z
        projection[2, 2] = -fx * (x - baseline) * inverse_z ** 2
        rotation = world_to_camera[m]
        for i in range(rows):
            for j in range(3):
                point_jacobian[i, j] = (projection[i, 0] * rotation[0, j] + projection[i, 1] * rotation[1, j]
                                        + projection[i, 2] * rotation[2, j])
        p = point[m]
        for a in range(3):
            for b in range(3):
                total = 0.0
                for i in range(rows):
                    total += point_jacobian[i, a] * point_jacobian[i, b]
                hessian_points[p, a, b] += w * total
            total = 0.0
            for i in range(rows):
                total += point_jacobian[i, a] * error[m, i]
            gradient_points[p, a] -= w * total
        if not free[m]:
            continue
        for i in range(rows):  # (-R^T, 2 [p]x) with R^T = world_to_camera
            for j in range(3):
                camera_jacobian[i, j] = -point_jacobian[i, j]
            camera_jacobian[i, 3] = 2.0 * (projection[i, 1] * z - projection[i, 2] * y)
            camera_jacobian[i, 4] = 2.0 * (projection[i, 2] * x - projection[i, 0] * z)
            camera_jacobian[i, 5] = 2.0 * (projection[i, 0] * y - projection[i, 1] * x)
        for a in range(6):
            for b in range(6):
                total = 0.0
                for i in range(rows):
                    total += camera_jacobian[i, a] * camera_jacobian[i, b]
                hessian_camera[a, b] += w * total
            total = 0.0
            for i in range(rows):
                total += camera_jacobian[i, a] * error[m, i]
            gradient_camera[a] -= w * total
            for b in range(3):
                total = 0.0
                for i in range(rows):
                    total += camera_jacobian[i, a] * point_jacobian[i, b]
                coupling[p, a, b] += w * total


def skew(vectors: np.ndarray) -> np.ndarray:
    """(M, 3, 3) matrices ``[p]x`` with ``[p]x v = p x v``."""
    result = np.zeros((len(vectors), 3, 3))
    result[:, 0, 1], result[:, 0, 2] = -vectors[:, 2], vectors[:, 1]
    result[:, 1, 0], result[:, 1, 2] = vectors[:, 2], -vectors[:, 0]
    result[:, 2, 0], result[:, 2, 1] = -vectors[:, 1], vectors[:, 0]
    return result


def inverse_3x3(matrices: np.ndarray) -> np.ndarray:
    """Inverses of (N, 3, 3) matrices by their adjugates; LinAlgError when one is singular."""
    a = matrices
    adjugate = np.empty_like(a)
    adjugate[:, 0, 0] = a[:, 1, 1] * a[:, 2, 2] - a[:, 1, 2] * a[:, 2, 1]
    adjugate[:, 0, 1] = a[:, 0, 2] * a[:, 2, 1] - a[:, 0, 1] * a[:, 2, 2]
    adjugate[:, 0, 2] = a[:, 0, 1] * a[:, 1, 2] - a[:, 0, 2] * a[:, 1, 1]
    adjugate[:, 1, 0] = a[:, 1, 2] * a[:, 2, 0] - a[:, 1, 0] * a[:, 2, 2]
    adjugate[:, 1, 1] = a[:, 0, 0] * a[:, 2, 2] - a[:, 0, 2] * a[:, 2, 0]
    adjugate[:, 1, 2] = a[:, 0, 2] * a[:, 1, 0] - a[:, 0, 0] * a[:, 1, 2]
    adjugate[:, 2, 0] = a[:, 1, 0] * a[:, 2, 1] - a[:, 1, 1] * a[:, 2, 0]
    adjugate[:, 2, 1] = a[:, 0, 1] * a[:, 2, 0] - a[:, 0, 0] * a[:, 2, 1]
    adjugate[:, 2, 2] = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    determinant = np.einsum("ni,ni->n", a[:, 0, :], adjugate[:, :, 0])
    if not np.all(np.abs(determinant) > 0):
        raise np.linalg.LinAlgError("singular point block")
    return adjugate / determinant[:, None, None]


def schur_step(system, damping: float, active: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Camera and point steps of the damped system (H + damping I) dx = b, the points
    eliminated first (inactive points do not move); None when it cannot be solved."""
    hessian_camera, gradient_camera, hessian_points, gradient_points, coupling = system
    identity = np.eye(3)
    damped_points = np.where(active[:, None, None], hessian_points + damping * identity, identity)
    try:
        inverse = inverse_3x3(damped_points)
        coupled = (coupling @ inverse).transpose(1, 0, 2).reshape(6, -1)      # (6, 3N)
        reduced = hessian_camera + damping * np.eye(6) - coupled @ coupling.transpose(1, 0, 2).reshape(6, -1).T
        camera_step = np.linalg.solve(reduced, gradient_camera - coupled @ gradient_points.ravel())
    except np.linalg.LinAlgError:
        return None
    point_step = np.einsum("nij,nj->ni", inverse, gradient_points - (camera_step @ coupling))
    point_step[~active] = 0.0
    return camera_step, point_step


def predicted_decrease(step: tuple[np.ndarray, np.ndarray], system, damping: float, active: np.ndarray) -> float:
    """g2o's computeScale: dx . (damping dx + b) over the camera and the active points."""
    camera_step, point_step = step
    camera = camera_step @ (damping * camera_step + system[1])
    return float(camera + np.sum(point_step[active] * (damping * point_step[active] + system[3][active])))


def levenberg_marquardt(problem: _Problem, pose: np.ndarray, points: np.ndarray, kept: np.ndarray,
                        iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """g2o's OptimizationAlgorithmLevenberg over the kept edges (see the module docstring)."""
    active = np.bincount(problem.point[kept], minlength=problem.point_count) > 0
    current = problem.evaluate(pose, points, kept)
    damping, growth = 0.0, 2.0
    for iteration in range(iterations):
        system = problem.normal_equations(current, kept)
        if iteration == 0:
            largest = max(np.diag(system[0]).max(), np.diagonal(system[2][active], axis1=1, axis2=2).max(initial=0.0))
            damping, growth = LAMBDA_INIT_FACTOR * largest, 2.0
        trials, gain = 0, -1.0
        while gain < 0 and trials < MAX_TRIALS_AFTER_FAILURE:
            step = schur_step(system, damping, active)
            trial = None if step is None else problem.evaluate(updated_pose(current.pose, step[0]),
                                                               current.points + step[1], kept)
            gain = -np.inf
            if trial is not None and np.isfinite(trial.cost):
                gain = (current.cost - trial.cost) / (predicted_decrease(step, system, damping, active) + SCALE_EPSILON)
            if gain > 0:
                damping *= max(GOOD_STEP_LOWER_SCALE, min(GOOD_STEP_UPPER_SCALE, 1 - (2 * gain - 1) ** 3))
                growth, current = 2.0, trial
            else:
                damping *= growth
                growth *= 2
            trials += 1
        if trials == MAX_TRIALS_AFTER_FAILURE or gain == 0 or not np.isfinite(damping):
            break
    return current.pose, current.points


def adjust_frame(pose: np.ndarray, points: np.ndarray, observations: Observations, held: dict[int, np.ndarray],
                 link: Link | None, K: np.ndarray, settings: BundleSettings) -> BundleResult:
    """Refine ``pose`` (``T_world_camera`` of the frame whose observations have frame
    FREE_FRAME) and the observed ``points`` (N, 3, world) with the ``held`` key-frame poses
    fixed; see the module docstring for the passes and the outlier rule."""
    problem = _Problem(observations, held, link, K, settings, len(points))
    points = np.array(points, dtype=np.float64)
    kept = np.ones(len(observations), bool)
    outliers = np.zeros(len(points), bool)
    passes = (FIRST_PASS_ITERATIONS, settings.iterations) if settings.kernel_delta > 0 else (settings.iterations,)
    for iterations in passes:
        pose, points = levenberg_marquardt(problem, pose, points, kept, iterations)
        if settings.kernel_delta <= 0:
            break
        dropped = kept & (problem.chi2(pose, points) > settings.kernel_delta)
        kept &= ~dropped
        outliers[problem.point[dropped]] = True
    return BundleResult(pose, points, outliers)
