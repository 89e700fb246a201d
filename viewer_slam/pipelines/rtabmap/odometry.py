"""Frame-to-map visual odometry (RTAB-Map's Odom/Strategy 0, OdometryF2M).

Each frame's features are matched to a local map of 3D features. With a motion guess
(Odom/GuessMotion: the last inter-frame motion as a velocity, translation and Euler angles
per second, times the time since the last frame), map points are projected with it and a
feature may only match a map point predicted within Vis/CorGuessWinSize pixels, the ratio
test applied among those candidates; if that registration fails, or when there is no
guess (the frame after a loss: odometry clears its velocity when lost), the frame is
matched against the whole local map by descriptor alone (through a word dictionary, as
RegistrationVis matches: :mod:`.correspondences`), and a registration found so is made
again guided by its own pose (Reg/RepeatOnce), so that its matches and inliers are those of
the guided matching. PnP RANSAC gives each pose,
accepted with at least Vis/MinInliers inliers. The local map grows on key frames (inliers
at most Odom/KeyFrameThr of the features or Odom/VisKeyFrameThr) and is capped at
OdomF2M/MaxSize in RTAB-Map's order of removal (:meth:`LocalMap.cap`). With
OdomF2M/BundleAdjustment each registration is then refined by a local bundle adjustment
against the key frames that saw its inliers (:mod:`.bundle`): the pose becomes the
adjusted one, the points whose observations disagree are no longer inliers, and on a key
frame the inlier map points move to their adjusted positions.
After Odom/ResetCountdown lost frames odometry starts a new map from
the last good pose; the first frame of a map carries no link to what came before, which
is what makes RTAB-Map start a new graph session there.
"""

from collections import Counter
from dataclasses import dataclass, field
from itertools import chain, repeat

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from ...backend.local_bundle import Link, adjust_frame
from ...frontend.features import Features
from ...frontend.hamming import nearest_within_radius
from ...frontend.pnp import solve_pnp_ransac
from ...geometry.camera import Camera
from ...geometry.se3 import invert, transform_points
from .bundle import KeyFrames, Reference, bundle_observations, key_frame_of
from .correspondences import TreeSeeds, word_matches
from .graph import Variance, registration_variance
from .params import RtabmapParams
from .window import has_neighbour_within

MIN_DEPTH_OF_PROJECTION = 0.1
# With bundle adjustment RTAB-Map scales each variance of the registration down by 10 where
# it exceeds ten times Registration::COVARIANCE_LINEAR_EPSILON (1e-8) or, for rotation,
# COVARIANCE_ANGULAR_EPSILON (3e-8).
BUNDLE_VARIANCE_SCALE = 0.1
BUNDLE_TRANSLATION_VARIANCE_FLOOR = 1e-7
BUNDLE_ROTATION_VARIANCE_FLOOR = 3e-7


def all_but(indices: np.ndarray, count: int) -> np.ndarray:
    """The indices below ``count`` that are not among ``indices``, ascending (``np.setdiff1d``
    of ``arange(count)``, without its sort)."""
    left = np.ones(count, bool)
    left[indices] = False
    return np.flatnonzero(left)


class LocalMap:
    """3D features in the odometry frame, oldest first (RTAB-Map's word ids grow with each
    word added), with their descriptors, the key frame that added each and, per point, the
    key frames' observations of it (for the bundle adjustment). ``referenced`` counts the
    observations per key frame, so that the key frames no point refers to any more are found
    without reading every point's observations."""

    def __init__(self):
        self.points = np.zeros((0, 3))
        self.descriptors = np.zeros((0, 32), np.uint8)
        self.added_on = np.zeros(0, int)
        self.references: list[list[Reference]] = []
        self.referenced: Counter[int] = Counter()

    def __len__(self) -> int:
        return len(self.points)

    def add(self, points: np.ndarray, descriptors: np.ndarray, frame: int, references: list[Reference]) -> None:
        self.points = np.concatenate([self.points, points])
        self.descriptors = np.concatenate([self.descriptors, descriptors])
        self.added_on = np.concatenate([self.added_on, np.full(len(points), frame)])
        self.references += [[reference] for reference in references]
        self.referenced.update(map(key_frame_of, references))

    def refer(self, indices: np.ndarray, references: list[Reference]) -> None:
        for index, reference in zip(indices.tolist(), references):
            self.references[index].append(reference)
        self.referenced.update(map(key_frame_of, references))

    def cap(self, max_size: int, first: np.ndarray, kept: np.ndarray, added: int) -> None:
        """OdometryF2M's removal beyond OdomF2M/MaxSize on a key frame: the points ``first``
        in their order (the registration's matched map points that are not inliers, then
        the previous key frame's points that the guided matching projected near a corner),
        then the oldest, never one of ``kept`` (the registration's inliers), and no further
        than ``added`` points less one (the key frame's new points), so that a key frame that
        adds more than ``max_size`` points keeps them all."""
        target = max(max_size, added - 1)
        if len(self) <= target:
            return
        candidates = np.concatenate([first, np.arange(len(self))]).astype(int)
        _, first_place = np.unique(candidates, return_index=True)
        candidates = candidates[np.sort(first_place)]
        protected = np.zeros(len(self), bool)
        protected[kept] = True
        removed = candidates[~protected[candidates]][: len(self) - target]
        references = self.references
        self.referenced.subtract(
            Counter(map(key_frame_of, chain.from_iterable(map(references.__getitem__, removed.tolist()))))
        )
        self.referenced = +self.referenced  # drop the key frames counted down to 0
        keep = all_but(removed, len(self))
        self.points, self.descriptors = self.points[keep], self.descriptors[keep]
        self.added_on = self.added_on[keep]
        self.references = [references[i] for i in keep.tolist()]


@dataclass
class OdometryResult:
    """What one frame's registration produced.

    ``pose`` is ``T_odom_camera`` (None when lost); ``new_session`` is set on the frame
    that starts a map (the first one, or with ``reset`` the first after a reset). ``matched_pixels`` and
    ``projected_pixels`` are the current keypoints of the matches and their map points
    projected with the estimated (or, when lost, the last) pose, for the map points in
    front of that camera, ``inlier_mask`` which of those are inliers; ``variance`` that of
    the registration (see :func:`registration_variance`); ``feature_index``,
    ``map_index`` and ``match_inliers`` all the matches (indices in the frame's features and
    in the local map) and which are inliers; ``map_points`` the inliers' map points after
    bundle adjustment (as they were without it); ``projected`` the map points the guided
    matching projected within Vis/CorGuessWinSize of a corner (RegistrationVis's
    ``projectedIDs``; none for a registration by descriptors alone).
    """

    pose: np.ndarray | None
    new_session: bool = False
    matches: int = 0
    inliers: int = 0
    reset: bool = False
    matched_pixels: np.ndarray | None = None
    projected_pixels: np.ndarray | None = None
    inlier_mask: np.ndarray | None = None
    variance: Variance = Variance()
    feature_index: np.ndarray | None = None
    map_index: np.ndarray | None = None
    match_inliers: np.ndarray | None = None
    map_points: np.ndarray | None = None
    key_frame: bool = False
    local_map_size: int = 0
    kept: np.ndarray | None = None
    projected: np.ndarray = field(default_factory=lambda: np.zeros(0, int))


def scaled_down(variance: float, floor: float) -> float:
    """A variance after the bundle adjustment: BUNDLE_VARIANCE_SCALE times it where it exceeds ``floor``."""
    return variance * BUNDLE_VARIANCE_SCALE if variance > floor else variance


def velocity_of(motion: np.ndarray, elapsed: float) -> np.ndarray:
    """Odometry::process's velocity: the motion's translation and Euler angles (yaw, pitch,
    roll of R = Rz Ry Rx) over the time it took, per second."""
    return np.r_[motion[:3, 3], Rotation.from_matrix(motion[:3, :3]).as_euler("ZYX")] / elapsed


def motion_over(velocity: np.ndarray, elapsed: float) -> np.ndarray:
    """The motion guess: each of the velocity's six components times ``elapsed`` seconds."""
    scaled = velocity * elapsed
    motion = np.eye(4)
    motion[:3, :3] = Rotation.from_euler("ZYX", scaled[3:]).as_matrix()
    motion[:3, 3] = scaled[:3]
    return motion


def guided_matches(
    points: np.ndarray,
    descriptors: np.ndarray,
    corners: np.ndarray,
    corner_descriptors: np.ndarray,
    predicted: np.ndarray,
    camera: Camera,
    params: RtabmapParams,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RegistrationVis's matching with a motion guess: the 3D ``points`` (with their
    ``descriptors``) in front of the ``predicted`` camera whose projection lies in the
    (rectified) image are matched with the ``corners`` (pinhole pixels) within
    Vis/CorGuessWinSize pixels; returned are the matches (indices of corners, of points) and
    the points projected within the window of a corner. By default each projected point, in
    word order, picks among the corners around it and a corner already taken is not matched
    again; with Vis/CorGuessMatchToProjection each corner picks among the projected points
    around it, and a point picked by several corners is dropped (their duplicate word ids are
    removed before the motion estimation)."""
    in_camera = transform_points(invert(predicted), points)
    in_front = np.flatnonzero(in_camera[:, 2] > 0)
    projections = camera.project(in_camera[in_front])
    inside = (
        (projections >= 0).all(axis=1)
        & (projections[:, 0] <= camera.width - 1)
        & (projections[:, 1] <= camera.height - 1)
    )
    visible, projections = in_front[inside], projections[inside]
    projected = visible[has_neighbour_within(projections, corners, params.guess_window)]
    visible_descriptors = descriptors[visible]
    if params.guess_match_to_projection:
        picked = nearest_within_radius(
            corners,
            corner_descriptors,
            projections,
            visible_descriptors,
            params.guess_window,
            params.correspondence_nndr,
        )
        claims = np.bincount(picked[picked >= 0], minlength=len(visible))
        corner_index = np.flatnonzero(picked >= 0)
        corner_index = corner_index[claims[picked[corner_index]] == 1]
        return corner_index, visible[picked[corner_index]], projected
    picked = nearest_within_radius(
        projections, visible_descriptors, corners, corner_descriptors, params.guess_window, params.correspondence_nndr
    )
    matched = np.flatnonzero(picked >= 0)
    _, first_claim = np.unique(picked[matched], return_index=True)
    point_rows = np.sort(matched[first_claim])
    return picked[point_rows], visible[point_rows], projected


def pinhole_pixels(camera: Camera, keypoints: np.ndarray) -> np.ndarray:
    """Pixel coordinates as a pinhole camera would see them (RTAB-Map expects rectified images)."""
    if not any(camera.distortion) or len(keypoints) == 0:  # OpenCV 4 returns None for no points
        return keypoints.astype(np.float64).reshape(-1, 2)
    return cv2.undistortPoints(
        keypoints.reshape(-1, 1, 2).astype(np.float64), camera.K, np.asarray(camera.distortion), P=camera.K
    ).reshape(-1, 2)


class FrameToMapOdometry:
    """Registers each frame to the local map; see the module docstring."""

    def __init__(self, camera: Camera, params: RtabmapParams, tree_seeds: TreeSeeds | None = None):
        self.camera = camera
        self.params = params
        self.tree_seeds = tree_seeds or TreeSeeds(0)
        self.map = LocalMap()
        self.key_frames = KeyFrames()
        self.pose: np.ndarray | None = None  # last registered pose
        self.stamp: float | None = None  # its time; None after a loss
        self.velocity: np.ndarray | None = None  # see velocity_of; None: no guess
        self.lost_frames = 0
        self.frame_count = 0
        self.was_reset = False
        self.last_key_frame = 0  # the frame of the newest key frame

    @property
    def initialised(self) -> bool:
        return len(self.map) > 0

    def process(self, features: Features, timestamp: float) -> OdometryResult:
        """Register the frame taken at ``timestamp`` (seconds). As Odometry::process, the
        velocity is only known after two registered frames in a row, so the first frame
        of a map and the first after a loss are followed by one without a guess."""
        self.frame_count += 1
        if not self.initialised:
            result = self._start_map(features)
            self.stamp = timestamp if result.pose is not None else None
            return result
        assert self.pose is not None  # a started map started from a pose (_start_map)
        elapsed = timestamp - self.stamp if self.stamp is not None else 0.0
        guess = motion_over(self.velocity, elapsed) if self.velocity is not None and elapsed > 0 else None
        result = self._register(features, guess)
        if result.pose is not None:
            self.velocity = velocity_of(invert(self.pose) @ result.pose, elapsed) if elapsed > 0 else None
            self.pose, self.stamp = result.pose, timestamp
            self.lost_frames = 0
            return result
        self.lost_frames += 1
        self.velocity, self.stamp = None, None
        if self.params.reset_countdown > 0 and self.lost_frames >= self.params.reset_countdown:
            self.reset()
            return self._start_map(features)
        return result

    def reset(self) -> None:
        """Odometry::reset(pose): forget the local map; the next usable frame starts a new
        one at the last registered pose."""
        self.map = LocalMap()
        self.key_frames = KeyFrames()
        self.velocity = None
        self.lost_frames = 0
        self.was_reset = True

    def _start_map(self, features: Features) -> OdometryResult:
        with_depth = features.has_depth
        if with_depth.sum() < self.params.min_inliers:
            return OdometryResult(pose=None)
        if self.pose is None:
            self.pose = np.eye(4)
        self.velocity = None
        self.last_key_frame = self.frame_count
        self.key_frames.add(self.frame_count, self.pose.copy())
        new = np.flatnonzero(with_depth)
        self.map.add(
            transform_points(self.pose, features.points[new]),
            features.descriptors[new],
            self.frame_count,
            self._references(features, new),
        )
        reset, self.was_reset = self.was_reset, False
        return OdometryResult(
            pose=self.pose.copy(), new_session=True, reset=reset, key_frame=True, local_map_size=len(self.map)
        )

    def _register(self, features: Features, guess: np.ndarray | None) -> OdometryResult:
        """Registration with the motion guess, then, if that fails or there is none, against
        the whole local map (OdometryF2M::computeTransform's second try without a guess),
        redone with its own pose as the guess (Registration::computeTransformationMod with
        Reg/RepeatOnce: the whole-map ratio test leaves out every map point whose descriptor
        looks like another's, the window around its projection does not) on the features the
        first registration left (:func:`~.correspondences.word_matches`' ``kept``)."""
        assert self.pose is not None  # registration follows _start_map, which sets the pose
        result = None
        if guess is not None and self.params.guess_window > 0:
            predicted = self.pose @ guess
            result = self._solve_guided(features, predicted)
        if result is None or result.pose is None:
            matches = word_matches(
                features.descriptors,
                self.map.descriptors,
                self.params.correspondence_nndr,
                self.params.correspondence_nn_type,
                self.tree_seeds,
            )
            repeats = self.params.repeat_once and self.params.guess_window > 0
            result = self._solve(features, matches.query, matches.train, self.pose, adjust=not repeats)
            if result.pose is not None and repeats:
                features = features.subset(matches.kept)
                result = self._solve_guided(features, result.pose)
                result.kept = matches.kept
        result.local_map_size = len(self.map)  # registered against (Odometry/LocalMapSize)
        if result.pose is not None:
            result.key_frame = self._update_map(features, result)
        return result

    def _solve_guided(self, features: Features, predicted: np.ndarray) -> OdometryResult:
        """The registration on the guided matches around ``predicted``, with the map points
        the matching projected near a corner (the local map's cap removes those of the
        previous key frame early)."""
        feature_index, map_index, projected = self.guided_matches(features, predicted)
        result = self._solve(features, feature_index, map_index, predicted)
        result.projected = projected
        return result

    def guided_matches(self, features: Features, predicted: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The local map's points matched to the frame's corners around their projections from
        ``predicted`` (:func:`guided_matches`)."""
        return guided_matches(
            self.map.points,
            self.map.descriptors,
            pinhole_pixels(self.camera, features.keypoints),
            features.descriptors,
            predicted,
            self.camera,
            self.params,
        )

    def _solve(
        self,
        features: Features,
        feature_index: np.ndarray,
        map_index: np.ndarray,
        shown_without_pose: np.ndarray,
        adjust: bool = True,
    ) -> OdometryResult:
        """PnP RANSAC on the matches, then, when ``adjust``, (OdomF2M/BundleAdjustment) the
        local bundle adjustment; the matched map points are shown projected with the estimated
        pose, or ``shown_without_pose`` when registration failed. A registration Reg/RepeatOnce
        makes again is not adjusted: RTAB-Map repeats it inside the registration
        (``Registration::computeTransformationMod``), and OdometryF2M adjusts only what that returns."""
        params = self.params
        solution = solve_pnp_ransac(
            self.map.points[map_index],
            features.keypoints[feature_index],
            self.camera.K,
            reprojection_error=params.pnp_inlier_distance,
            distortion=self.camera.distortion,
            iterations=params.ransac_iterations,
            min_inliers=params.min_inliers,
            refine_iterations=params.pnp_refine_iterations,
            refine_distance=params.pnp_reprojection_error,
        )
        pose = solution.pose if solution is not None else None
        inliers = solution.inliers if solution is not None else np.zeros(len(map_index), bool)
        variance, map_points = Variance(), None
        if pose is not None:
            variance = registration_variance(
                transform_points(invert(pose), self.map.points[map_index[inliers]]),
                features.points[feature_index[inliers]],
            )
            map_points = self.map.points[map_index[inliers]]
            if adjust and params.bundle_adjustment:
                pose, inliers, map_points, variance = self._bundle_adjust(
                    features, feature_index, map_index, inliers, pose, variance
                )
        in_camera = transform_points(
            invert(pose if pose is not None else shown_without_pose), self.map.points[map_index]
        )
        shown = in_camera[:, 2] > MIN_DEPTH_OF_PROJECTION
        return OdometryResult(
            pose=pose,
            matches=len(map_index),
            inliers=int(inliers.sum()),
            matched_pixels=features.keypoints[feature_index[shown]],
            projected_pixels=self.camera.project(in_camera[shown]),
            inlier_mask=inliers[shown],
            variance=variance,
            feature_index=feature_index,
            map_index=map_index,
            match_inliers=inliers,
            map_points=map_points,
        )

    def _bundle_adjust(
        self,
        features: Features,
        feature_index: np.ndarray,
        map_index: np.ndarray,
        inliers: np.ndarray,
        pose: np.ndarray,
        variance: Variance,
    ):
        """The registration refined against the key frames that saw its inliers: the
        adjusted pose, the inliers without the bundle's outliers (no pose when fewer than
        Vis/MinInliers remain), their adjusted map points and the variance scaled down."""
        inlier_rows = np.flatnonzero(inliers)
        points, features_used = map_index[inlier_rows], feature_index[inlier_rows]
        observations = bundle_observations(
            [self.map.references[i] for i in points],
            pinhole_pixels(self.camera, features.keypoints[features_used]),
            features.points[features_used, 2],
            self.params.bundle_max_frames,
        )
        last = self.key_frames.last
        assert last is not None  # _start_map added the map's first key frame
        link = Link(last, invert(self.key_frames.poses[last]) @ pose, variance.translation, variance.rotation)
        seen_by = {*np.unique(observations.frame[observations.frame >= 0]).tolist(), last}
        held = {frame: self.key_frames.poses[frame] for frame in seen_by}
        adjusted = adjust_frame(
            pose, self.map.points[points], observations, held, link, self.camera.K, self.params.bundle_settings
        )
        inliers = inliers.copy()
        inliers[inlier_rows[adjusted.outliers]] = False
        if inliers.sum() < self.params.min_inliers:
            return None, np.zeros(len(map_index), bool), None, Variance()
        scaled = Variance(
            scaled_down(variance.translation, BUNDLE_TRANSLATION_VARIANCE_FLOOR),
            scaled_down(variance.rotation, BUNDLE_ROTATION_VARIANCE_FLOOR),
        )
        return adjusted.pose, inliers, adjusted.points[~adjusted.outliers], scaled

    def _references(self, features: Features, index: np.ndarray) -> list[Reference]:
        """This frame's observations of its features ``index``, for the bundle adjustment."""
        pixels = pinhole_pixels(self.camera, features.keypoints[index])
        depth = features.points[index, 2]
        return list(
            zip(repeat(self.frame_count, len(index)), pixels[:, 0].tolist(), pixels[:, 1].tolist(), depth.tolist())
        )

    def _update_map(self, features: Features, result: OdometryResult) -> bool:
        """On a key frame, move the inliers' map points to their adjusted positions, record
        this frame's observations of every matched map point and add the features that
        matched none; True on a key frame (OdometryF2M::computeTransform: a matched feature
        carries its map word's id, inlier or not, so it is an observation of that word and
        never a new one)."""
        params = self.params
        # A registered result (_solve's, with a pose) carries its matches.
        assert result.pose is not None and result.map_index is not None and result.feature_index is not None
        inlier_points = result.map_index[result.match_inliers]
        if (
            params.keyframe_threshold == 0
            or params.keyframe_inliers == 0
            or result.inliers <= params.keyframe_threshold * len(features)
            or result.inliers <= params.keyframe_inliers
        ):
            if params.bundle_adjustment:
                self.key_frames.add(self.frame_count, result.pose)
                self.map.points[inlier_points] = result.map_points
                self.map.refer(result.map_index, self._references(features, result.feature_index))
            self._extend_map(features, result, all_but(result.feature_index, len(features)))
            return True
        return False

    def _extend_map(self, features: Features, result: OdometryResult, candidates: np.ndarray) -> None:
        """Add the frame's unregistered features with depth, then cap the map: first the
        matched map points that are not inliers, then the previous key frame's points
        projected near a corner, then the oldest (:meth:`LocalMap.cap`)."""
        assert result.pose is not None and result.map_index is not None and result.match_inliers is not None
        new = candidates[features.has_depth[candidates]]
        outliers = np.sort(result.map_index[~result.match_inliers])
        previous_key_frames = np.sort(result.projected[self.map.added_on[result.projected] >= self.last_key_frame])
        self.map.add(
            transform_points(result.pose, features.points[new]),
            features.descriptors[new],
            self.frame_count,
            self._references(features, new),
        )
        self.map.cap(
            self.params.local_map_size,
            np.concatenate([outliers, previous_key_frames]),
            result.map_index[result.match_inliers],
            len(new),
        )
        self.last_key_frame = self.frame_count
        self.key_frames.keep_referenced(self.map.referenced)
