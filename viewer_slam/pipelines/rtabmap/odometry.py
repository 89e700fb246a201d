"""Frame-to-map visual odometry (RTAB-Map's Odom/Strategy 0).

Each frame's features are matched to a local map of 3D features: map points are projected
with the constant-velocity prediction, a feature may only match a map point whose
prediction falls within Vis/CorGuessWinSize pixels, and the ratio test is applied among
those candidates; PnP RANSAC then gives the pose. The local map grows on key frames and
is capped at OdomF2M/MaxSize. When registration fails the odometry reports no pose and
keeps trying against the same map from the last pose, which is why RTAB-Map stays lost
once the camera has been carried elsewhere, unless Odom/ResetCountdown starts a new map.
"""

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ...frontend.features import Features
from ...frontend.pnp import solve_pnp_ransac
from ...geometry.camera import Camera
from ...geometry.se3 import invert, transform_points
from .graph import registration_variance
from .params import RtabmapParams

# A lone candidate inside the window has no second neighbour for the ratio test; it is kept
# only when its Hamming distance is typical of a true ORB/BRIEF match (of 256 bits).
LONE_CANDIDATE_MAX_DISTANCE = 64
MIN_DEPTH_OF_PROJECTION = 0.1
# Map points projected nearest to a feature (within the window) that compete for it.
GUIDED_CANDIDATES = 24


class LocalMap:
    """3D features in the odometry frame with their descriptors and observation history."""

    def __init__(self):
        self.points = np.zeros((0, 3))
        self.descriptors = np.zeros((0, 32), np.uint8)
        self.times_seen = np.zeros(0, int)
        self.last_seen = np.zeros(0, int)

    def __len__(self) -> int:
        return len(self.points)

    def add(self, points: np.ndarray, descriptors: np.ndarray, frame: int) -> None:
        self.points = np.concatenate([self.points, points])
        self.descriptors = np.concatenate([self.descriptors, descriptors])
        self.times_seen = np.concatenate([self.times_seen, np.ones(len(points), int)])
        self.last_seen = np.concatenate([self.last_seen, np.full(len(points), frame)])

    def observe(self, indices: np.ndarray, frame: int) -> None:
        self.times_seen[indices] += 1
        self.last_seen[indices] = frame

    def cap(self, max_size: int) -> None:
        """Keep the ``max_size`` most recently seen points, the most often seen first among equals."""
        if len(self) <= max_size:
            return
        keep = np.sort(np.lexsort((-self.times_seen, -self.last_seen))[:max_size])
        self.points, self.descriptors = self.points[keep], self.descriptors[keep]
        self.times_seen, self.last_seen = self.times_seen[keep], self.last_seen[keep]


@dataclass
class OdometryResult:
    """What one frame's registration produced.

    ``pose`` is ``T_odom_camera`` (None when lost); ``new_session`` is set on the frame
    that starts a map (the first one, or with ``reset`` the first after a reset). ``matched_pixels`` and
    ``projected_pixels`` are the current keypoints of the matches and their map points
    projected with the estimated (or, when lost, the predicted) pose; ``variance`` that of
    the registration (m², see :func:`registration_variance`).
    """

    pose: np.ndarray | None
    new_session: bool = False
    matches: int = 0
    inliers: int = 0
    reset: bool = False
    matched_pixels: np.ndarray | None = None
    projected_pixels: np.ndarray | None = None
    inlier_mask: np.ndarray | None = None
    variance: float = 0.0


def hamming_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamming distances between two equally long arrays of binary descriptors."""
    return np.bitwise_count(np.bitwise_xor(a, b)).sum(axis=1, dtype=np.int32)


def guided_matches(keypoints: np.ndarray, descriptors: np.ndarray, projections: np.ndarray,
                   map_descriptors: np.ndarray, window: float, nndr: float) -> tuple[np.ndarray, np.ndarray]:
    """Matches (feature index, map index) between features and the map points projected
    nearest to them, within ``window`` pixels, that pass the ratio test among those
    candidates; each map point keeps its closest feature."""
    if len(keypoints) == 0 or len(projections) < 2:
        return np.zeros(0, int), np.zeros(0, int)
    k = min(GUIDED_CANDIDATES, len(projections))
    _, candidates = cKDTree(projections).query(keypoints, k=k, distance_upper_bound=window, p=np.inf)
    found = candidates < len(projections)
    query = np.broadcast_to(np.arange(len(keypoints))[:, None], candidates.shape)[found]
    distance = np.full(candidates.shape, np.iinfo(np.int32).max)
    distance[found] = hamming_distances(descriptors[query], map_descriptors[candidates[found]])
    nearest_two = np.argsort(distance, axis=1, kind="stable")[:, :2]
    rows = np.arange(len(keypoints))
    best, second = distance[rows, nearest_two[:, 0]], distance[rows, nearest_two[:, 1]]
    lone = found.sum(axis=1) == 1
    passes = np.where(lone, best <= LONE_CANDIDATE_MAX_DISTANCE, best < nndr * second) & found.any(axis=1)
    query, train, distance = rows[passes], candidates[passes, nearest_two[passes, 0]], best[passes]
    best_first = np.argsort(distance, kind="stable")
    _, unique = np.unique(train[best_first], return_index=True)
    keep = np.sort(best_first[unique])
    return query[keep], train[keep]


class FrameToMapOdometry:
    """Registers each frame to the local map; see the module docstring."""

    def __init__(self, camera: Camera, params: RtabmapParams, seed: int = 0):
        self.camera = camera
        self.params = params
        self.seed = seed
        self.map = LocalMap()
        self.pose: np.ndarray | None = None      # last registered pose
        self.velocity = np.eye(4)                # last inter-frame motion, T_prev_current
        self.lost_frames = 0
        self.frame_count = 0
        self.was_reset = False

    @property
    def initialised(self) -> bool:
        return len(self.map) > 0

    def process(self, features: Features) -> OdometryResult:
        self.frame_count += 1
        if not self.initialised:
            return self._start_map(features)
        result = self._register(features)
        if result.pose is not None:
            self.velocity = invert(self.pose) @ result.pose if self.lost_frames == 0 else np.eye(4)
            self.pose = result.pose
            self.lost_frames = 0
            return result
        self.lost_frames += 1
        self.velocity = np.eye(4)
        if self.params.reset_countdown > 0 and self.lost_frames >= self.params.reset_countdown:
            self.reset()
            return self._start_map(features)
        return result

    def reset(self) -> None:
        """Forget the map and the pose; the next usable frame starts a new map at the origin."""
        self.map = LocalMap()
        self.pose = None
        self.velocity = np.eye(4)
        self.lost_frames = 0
        self.was_reset = True

    def _start_map(self, features: Features) -> OdometryResult:
        with_depth = features.has_depth
        if with_depth.sum() < self.params.min_inliers:
            return OdometryResult(pose=None)
        self.pose = np.eye(4)
        self.velocity = np.eye(4)
        self.map.add(features.points[with_depth], features.descriptors[with_depth], self.frame_count)
        reset, self.was_reset = self.was_reset, False
        return OdometryResult(pose=self.pose.copy(), new_session=True, reset=reset)

    def _register(self, features: Features) -> OdometryResult:
        params = self.params
        predicted = self.pose @ self.velocity
        in_camera = transform_points(invert(predicted), self.map.points)
        visible = np.flatnonzero(in_camera[:, 2] > MIN_DEPTH_OF_PROJECTION)
        projections = self.camera.project(in_camera[visible])
        margin = params.guess_window
        near_image = ((projections[:, 0] > -margin) & (projections[:, 0] < self.camera.width + margin)
                      & (projections[:, 1] > -margin) & (projections[:, 1] < self.camera.height + margin))
        visible, projections = visible[near_image], projections[near_image]
        feature_index, map_index = guided_matches(features.keypoints, features.descriptors, projections,
                                                  self.map.descriptors[visible], params.guess_window,
                                                  params.correspondence_nndr)
        map_index = visible[map_index]
        solution = solve_pnp_ransac(self.map.points[map_index], features.keypoints[feature_index], self.camera.K,
                                    reprojection_error=params.pnp_reprojection_error, distortion=self.camera.distortion,
                                    iterations=params.ransac_iterations, min_inliers=params.min_inliers,
                                    seed=self.seed)
        pose = solution.pose if solution is not None else None
        shown_pose = pose if pose is not None else predicted
        projected = self.camera.project(transform_points(invert(shown_pose), self.map.points[map_index])) \
            if len(map_index) else np.zeros((0, 2))
        inlier_mask = solution.inliers if solution is not None else np.zeros(len(map_index), bool)
        result = OdometryResult(pose=pose, matches=len(map_index), inliers=int(inlier_mask.sum()),
                                matched_pixels=features.keypoints[feature_index], projected_pixels=projected,
                                inlier_mask=inlier_mask)
        if pose is not None:
            inlier_features = feature_index[inlier_mask]
            result.variance = registration_variance(self.map.points[map_index[inlier_mask]],
                                                    transform_points(pose, features.points[inlier_features]))
            self.map.observe(map_index[inlier_mask], self.frame_count)
            if result.inliers < params.keyframe_threshold * len(features):
                self._extend_map(features, pose, np.setdiff1d(np.arange(len(features)), inlier_features))
        return result

    def _extend_map(self, features: Features, pose: np.ndarray, candidates: np.ndarray) -> None:
        """Add the frame's unregistered features with depth, then cap the map."""
        new = candidates[features.has_depth[candidates]]
        self.map.add(transform_points(pose, features.points[new]), features.descriptors[new], self.frame_count)
        self.map.cap(self.params.local_map_size)
