"""Bundle adjustment of one frame against fixed key frames, on GTSAM.

This is the problem RTAB-Map's frame-to-map odometry solves after each registration
(``OdometryF2M::computeTransform`` calling ``OptimizerG2O::optimizeBA`` with a negative
root): the new frame's pose and the 3D points it registered on are free, the key frames
that saw those points are held, each observation is a reprojection edge with the pixel
variance as noise under a Huber kernel, and a link ties the frame to the last key frame
with the registration's own uncertainty. An observation with depth is a stereo edge on a
fake baseline (RTAB-Map's g2o/Baseline for RGB-D): its third coordinate is
``u - fx * baseline / depth``, so the depth is weighed in pixels too; one without depth
is a plain projection.

The optimisation runs as g2o's does in RTAB-Map: a first pass of a few iterations, then
every edge whose squared error over the pixel variance exceeds the kernel's delta is
dropped and its point put back where it started, then the remaining iterations; edges
still over the delta after that mark their points as outliers too. GTSAM has no fixed
variable, so each held key frame carries a prior of a micrometre and a microradian.
"""

from dataclasses import dataclass

import gtsam
import numpy as np

from ..geometry.se3 import invert, transform_points

FIRST_PASS_ITERATIONS = 5        # OptimizerG2O::optimizeBA's first, robust-only pass
HELD_SIGMA = 1e-6                # prior (m and rad) that stands for g2o's fixed vertex
FREE_FRAME = -1                  # frame id of the observations made by the adjusted frame
FREE_KEY = gtsam.symbol("c", 0)


def _pose_key(frame: int) -> int:
    return FREE_KEY if frame == FREE_FRAME else gtsam.symbol("x", frame)


def _point_key(index: int) -> int:
    return gtsam.symbol("l", index)


def _pose_keys(frames: np.ndarray) -> list[int]:
    """``_pose_key`` of many frames at once (a GTSAM symbol is its character << 56 | index)."""
    keys = (ord("x") << 56) | np.maximum(frames, 0).astype(np.uint64)
    return np.where(frames == FREE_FRAME, np.uint64(FREE_KEY), keys).tolist()


def _point_keys(indices: np.ndarray) -> list[int]:
    return ((ord("l") << 56) | indices.astype(np.uint64)).tolist()


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
    points had an observation dropped (such a point is re-estimated from its other
    observations, or left where it started if the drop came after the last pass)."""

    pose: np.ndarray
    points: np.ndarray
    outliers: np.ndarray


def edge_chi2(pose_of: dict[int, np.ndarray], points: np.ndarray, observations: Observations,
              K: np.ndarray, baseline: float, pixel_variance: float) -> np.ndarray:
    """Squared reprojection error of each observation over the pixel variance (g2o's
    ``edge->chi2()``): (u, v, u - fx b / z) for a stereo edge, (u, v) for a mono one."""
    chi2 = np.empty(len(observations))
    for frame in np.unique(observations.frame):
        rows = np.flatnonzero(observations.frame == frame)
        in_camera = transform_points(invert(pose_of[frame]), points[observations.point[rows]])
        z = in_camera[:, 2]
        u = K[0, 0] * in_camera[:, 0] / z + K[0, 2]
        v = K[1, 1] * in_camera[:, 1] / z + K[1, 2]
        error = (u - observations.pixels[rows, 0]) ** 2 + (v - observations.pixels[rows, 1]) ** 2
        stereo = observations.stereo[rows]
        depth = observations.depth[rows[stereo]]
        disparity_error = K[0, 0] * baseline * (1 / depth - 1 / z[stereo])
        error[stereo] += (u[stereo] - observations.pixels[rows[stereo], 0] + disparity_error) ** 2
        chi2[rows] = error / pixel_variance
    return chi2


class _Problem:
    """The GTSAM factors of one adjustment, one per observation, plus the held frames and
    the link."""

    def __init__(self, pose: np.ndarray, points: np.ndarray, observations: Observations,
                 held: dict[int, np.ndarray], link: Link | None, K: np.ndarray, settings: BundleSettings):
        self.observations = observations
        self.settings = settings
        pixel_sigma = np.sqrt(settings.pixel_variance)
        robust = gtsam.noiseModel.mEstimator.Huber.Create(settings.kernel_delta) if settings.kernel_delta > 0 else None
        stereo_noise = gtsam.noiseModel.Isotropic.Sigma(3, pixel_sigma)
        mono_noise = gtsam.noiseModel.Isotropic.Sigma(2, pixel_sigma)
        if robust is not None:
            stereo_noise = gtsam.noiseModel.Robust.Create(robust, stereo_noise)
            mono_noise = gtsam.noiseModel.Robust.Create(robust, mono_noise)
        fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        stereo_calibration = gtsam.Cal3_S2Stereo(fx, fy, 0.0, cx, cy, settings.baseline)
        mono_calibration = gtsam.Cal3_S2(fx, fy, 0.0, cx, cy)
        self.common = gtsam.NonlinearFactorGraph()
        self.values = gtsam.Values()
        self.values.insert(FREE_KEY, gtsam.Pose3(pose))
        held_noise = gtsam.noiseModel.Isotropic.Sigma(6, HELD_SIGMA)
        for frame, held_pose in held.items():
            self.values.insert(_pose_key(frame), gtsam.Pose3(held_pose))
            self.common.add(gtsam.PriorFactorPose3(_pose_key(frame), gtsam.Pose3(held_pose), held_noise))
        if link is not None:
            sigma = np.sqrt(max(link.variance, HELD_SIGMA ** 2))
            self.common.add(gtsam.BetweenFactorPose3(_pose_key(link.frame), FREE_KEY, gtsam.Pose3(link.relative),
                                                     gtsam.noiseModel.Isotropic.Sigma(6, sigma)))
        for index in np.unique(observations.point):
            self.values.insert(_point_key(index), points[index])
        stereo = observations.stereo
        right = observations.pixels[:, 0] - fx * settings.baseline / np.where(stereo, observations.depth, 1.0)
        self.edges = []
        for (u, v), u_right, is_stereo, pose_key, point_key in zip(
                observations.pixels.tolist(), right.tolist(), stereo.tolist(), _pose_keys(observations.frame),
                _point_keys(observations.point)):
            if is_stereo:
                self.edges.append(gtsam.GenericStereoFactor3D(gtsam.StereoPoint2(u, u_right, v), stereo_noise,
                                                              pose_key, point_key, stereo_calibration))
            else:
                self.edges.append(gtsam.GenericProjectionFactorCal3_S2(gtsam.Point2(u, v), mono_noise, pose_key,
                                                                       point_key, mono_calibration))

    def optimise(self, values: gtsam.Values, kept: np.ndarray, iterations: int) -> gtsam.Values:
        """Levenberg-Marquardt (g2o/Optimizer 0) over the kept edges; points left without
        an edge are not variables of this pass."""
        graph = gtsam.NonlinearFactorGraph(self.common)
        for m in np.flatnonzero(kept):
            graph.add(self.edges[m])
        pass_values = gtsam.Values(values)
        for index in np.setdiff1d(self.observations.point, self.observations.point[kept]):
            pass_values.erase(_point_key(index))
        parameters = gtsam.LevenbergMarquardtParams()
        parameters.setMaxIterations(iterations)
        result = gtsam.LevenbergMarquardtOptimizer(graph, pass_values, parameters).optimize()
        values = gtsam.Values(values)
        values.update(result)
        return values


def adjust_frame(pose: np.ndarray, points: np.ndarray, observations: Observations, held: dict[int, np.ndarray],
                 link: Link | None, K: np.ndarray, settings: BundleSettings) -> BundleResult:
    """Refine ``pose`` (``T_world_camera`` of the frame whose observations have frame
    FREE_FRAME) and the observed ``points`` (N, 3, world) with the ``held`` key-frame poses
    fixed; see the module docstring for the passes and the outlier rule."""
    problem = _Problem(pose, points, observations, held, link, K, settings)
    observed = np.unique(observations.point)
    kept = np.ones(len(observations), bool)
    outliers = np.zeros(len(points), bool)
    values = problem.values
    passes = (FIRST_PASS_ITERATIONS, settings.iterations) if settings.kernel_delta > 0 else (settings.iterations,)
    for iterations in passes:
        values = problem.optimise(values, kept, iterations)
        if settings.kernel_delta <= 0:
            break
        estimate = _points(values, points, observed)
        pose_of = {frame: values.atPose3(_pose_key(frame)).matrix() for frame in np.unique(observations.frame)}
        chi2 = edge_chi2(pose_of, estimate, observations, K, settings.baseline, settings.pixel_variance)
        dropped = kept & (chi2 > settings.kernel_delta)
        kept &= ~dropped
        reset = np.unique(observations.point[dropped])
        outliers[reset] = True
        for index in reset:
            values.update(_point_key(index), points[index])
    return BundleResult(values.atPose3(FREE_KEY).matrix(), _points(values, points, observed), outliers)


def _points(values: gtsam.Values, initial: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """The ``observed`` points' current estimates; the others keep ``initial``."""
    estimate = np.array(initial, dtype=np.float64)
    for index, key in zip(observed.tolist(), _point_keys(observed)):
        estimate[index] = values.atPoint3(key)
    return estimate
