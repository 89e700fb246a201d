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
complement of the points (``BlockSolver_6_3``, points marginalised), compiled
(``bundle_solver``): the camera moves by ``t += dt`` and ``R = R q(dv)`` with ``q(dv)`` the
unit quaternion of vector part ``dv`` (g2o's ``SBACam::update``); the first damping is 1e-5
times the largest diagonal entry of the Hessian; a step is kept when it lowers the robust
chi2, the damping then scaled by ``max(1/3, min(2/3, 1 - (2 rho - 1)^3))``, and otherwise
undone with the damping multiplied by 2, 4, 8, ... for at most 10 trials, after which the
pass ends; the Huber kernel weighs each edge's information by ``rho'(chi2)``. As in
``optimizeBA`` there are two passes, 5 iterations and then Optimizer/Iterations; after each,
every edge whose chi2 (squared error over the pixel variance) exceeds the kernel's delta
leaves the optimisation and its point counts as an outlier.
"""

from dataclasses import dataclass

import numpy as np

from ..geometry.se3 import invert
from .bundle_solver import evaluate, levenberg_marquardt

FIRST_PASS_ITERATIONS = 5  # OptimizerG2O::optimizeBA's first, robust-only pass
FREE_FRAME = -1  # frame id of the observations made by the adjusted frame
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
    ``T_frame^-1 T_adjusted``, with the variance of each translation axis (m²) and of each
    rotation axis."""

    frame: int
    relative: np.ndarray
    translation_variance: float
    rotation_variance: float


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


def edge_chi2(
    pose_of: dict[int, np.ndarray],
    points: np.ndarray,
    observations: Observations,
    K: np.ndarray,
    baseline: float,
    pixel_variance: float,
) -> np.ndarray:
    """Squared reprojection error of each observation over the pixel variance (g2o's
    ``edge->chi2()``): (u, v, u - fx b / z) for a stereo edge, (u, v) for a mono one;
    ``pose_of`` holds the pose of every frame observing, FREE_FRAME's too if it is one."""
    settings = BundleSettings(pixel_variance=pixel_variance, baseline=baseline)
    problem = _Problem(observations, pose_of, None, K, settings)
    chi2 = np.empty(len(observations))
    chi2[problem.order] = problem.chi2(pose_of.get(FREE_FRAME, np.eye(4)), np.asarray(points, dtype=np.float64))
    return chi2


def link_terms(key_pose: np.ndarray, link: Link) -> tuple[np.ndarray, np.ndarray]:
    """g2o's EdgeSBACam from a fixed key frame to the adjusted frame, as the solver takes it:
    ``measured^-1 T_key^-1`` (the error is the translation and quaternion vector part of it
    times ``T_adjusted``, see ``bundle_solver.link_error``) and the information of each error
    component, 1/variance: RTAB-Map copies the covariance's inverse onto that error as it is."""
    translation, rotation = (
        1.0 / max(variance, LINK_VARIANCE_FLOOR) for variance in (link.translation_variance, link.rotation_variance)
    )
    return invert(link.relative) @ invert(key_pose), np.array([translation] * 3 + [rotation] * 3)


class _Problem:
    """The edges of one adjustment, sorted by point (which fixes the order of the per-point
    sums), with what stays fixed across iterations: the measured coordinates and the fixed
    key frames' world-to-camera transforms, in the compiled solver's layout."""

    def __init__(
        self,
        observations: Observations,
        held: dict[int, np.ndarray],
        link: Link | None,
        K: np.ndarray,
        settings: BundleSettings,
    ):
        self.order = np.argsort(observations.point, kind="stable")
        self.point = observations.point[self.order].astype(np.int64)
        self.free = observations.frame[self.order] == FREE_FRAME
        self.stereo = observations.stereo[self.order]
        self.measured = measurements(observations, K[0, 0], settings.baseline)[self.order]
        held_frames, held_edge = np.unique(observations.frame[self.order][~self.free], return_inverse=True)
        to_camera = np.stack([invert(held[frame]) for frame in held_frames.tolist()] or [np.eye(4)])
        self.held_rotation = np.zeros((len(self.point), 3, 3))
        self.held_translation = np.zeros((len(self.point), 3))
        self.held_rotation[~self.free] = to_camera[held_edge, :3, :3]
        self.held_translation[~self.free] = to_camera[held_edge, :3, 3]
        self.camera = np.array(
            [K[0, 0], K[1, 1], K[0, 2], K[1, 2], settings.baseline, settings.pixel_variance, settings.kernel_delta],
            dtype=np.float64,
        )
        self.link_to_measured: np.ndarray
        self.link_information: np.ndarray
        self.link_to_measured, self.link_information = (
            link_terms(held[link.frame], link) if link is not None else (np.eye(4), np.zeros(6))
        )

    def edges(
        self,
    ) -> tuple[
        np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray
    ]:
        """The edge arrays, camera and link, as the compiled solver takes them."""
        return (
            self.point,
            self.free,
            self.stereo,
            self.measured,
            self.held_rotation,
            self.held_translation,
            self.camera,
            self.link_to_measured,
            self.link_information,
        )

    def chi2(self, pose: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Each edge's chi2 (in the problem's edge order)."""
        count = len(self.point)
        chi2 = np.empty(count)
        evaluate(
            pose, points, np.ones(count, np.bool_), *self.edges(), np.empty((count, 3)), np.empty((count, 3)), chi2
        )
        return chi2

    def adjust(
        self, pose: np.ndarray, points: np.ndarray, kept: np.ndarray, iterations: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pose and points after one pass over the kept edges, and each edge's chi2 there."""
        return levenberg_marquardt(pose, points, kept, iterations, *self.edges())


def adjust_frame(
    pose: np.ndarray,
    points: np.ndarray,
    observations: Observations,
    held: dict[int, np.ndarray],
    link: Link | None,
    K: np.ndarray,
    settings: BundleSettings,
) -> BundleResult:
    """Refine ``pose`` (``T_world_camera`` of the frame whose observations have frame
    FREE_FRAME) and the observed ``points`` (N, 3, world) with the ``held`` key-frame poses
    fixed; see the module docstring for the passes and the outlier rule."""
    problem = _Problem(observations, held, link, K, settings)
    pose = np.array(pose, dtype=np.float64)
    points = np.array(points, dtype=np.float64)
    kept = np.ones(len(observations), bool)
    outliers = np.zeros(len(points), bool)
    passes = (FIRST_PASS_ITERATIONS, settings.iterations) if settings.kernel_delta > 0 else (settings.iterations,)
    for iterations in passes:
        pose, points, chi2 = problem.adjust(pose, points, kept, iterations)
        if settings.kernel_delta <= 0:
            break
        dropped = kept & (chi2 > settings.kernel_delta)
        kept &= ~dropped
        outliers[problem.point[dropped]] = True
    return BundleResult(pose, points, outliers)
