"""Node-to-node motion as v2's ``Node::matchNodePair``: descriptor matches (``featureMatching``),
the best ``max_matches`` of them, 3D-3D RANSAC under the Kinect noise model, and the edge's
information."""

from dataclasses import dataclass

import numpy as np

from ...frontend.features import Features, match_with_ratios
from ...frontend.hamming import PackedDescriptors, hamming_nearest_matches, hamming_ratio_matches
from ...frontend.ransac import ransac_rigid
from ...geometry.se3 import rotation_angle
from .params import RgbdSlamParams

# Floor on the RMS Mahalanobis distance in the edge information: exact synthetic data would
# otherwise give edges so certain that the optimiser could not move them at all.
MIN_RMS_MAHALANOBIS = 0.1
# v2 adds a uniform random offset below this to each match's distance (or ratio) before the
# matches are sorted, so that equal distances, frequent with ORB, sort at random.
SORT_JITTER = 1e-3


@dataclass
class MeasuredFeatures:
    """Keypoints that have a 3D point; binary descriptors also ``packed`` for matching, once
    here rather than at each of the dozen comparisons a frame and a node take part in."""

    features: Features
    packed: PackedDescriptors | None = None

    @classmethod
    def from_features(cls, features: Features) -> "MeasuredFeatures":
        measured = features.subset(features.has_depth)
        return cls(measured, PackedDescriptors.of(measured.descriptors) if measured.binary else None)

    @property
    def descriptors(self) -> "np.ndarray | PackedDescriptors":
        """The descriptors as the matchers take them: packed where binary."""
        return self.features.descriptors if self.packed is None else self.packed

    def __len__(self) -> int:
        return len(self.features)


@dataclass
class Motion:
    """``transform`` = ``T_node_frame`` (frame points into the node's camera frame).

    ``frame_index``/``node_index`` index the matched keypoints of both sides; ``inliers``
    is a mask over those matches; ``information`` is the 6x6 edge information (rotation first).
    """

    transform: np.ndarray
    frame_index: np.ndarray
    node_index: np.ndarray
    inliers: np.ndarray
    rms_mahalanobis: float
    information: np.ndarray

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


def g2o_information(weight: float) -> np.ndarray:
    """The information ``weight * I`` that v2 sets on g2o's EdgeSE3 error (translation,
    quaternion vector part ≈ half the rotation angle), in GTSAM's tangent order: rotation
    then translation."""
    return np.diag([weight / 4] * 3 + [weight] * 3)


def edge_information(inliers: int, rms_mahalanobis: float) -> np.ndarray:
    """v2's information ``I * inliers / rmse²``."""
    return g2o_information(inliers / max(rms_mahalanobis, MIN_RMS_MAHALANOBIS) ** 2)


def match(
    frame: MeasuredFeatures, node: MeasuredFeatures, params: RgbdSlamParams, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """v2's ``featureMatching``: the matches best first, at most ``max_matches`` of them
    (``keepStrongestMatches``), equal scores in random order.

    With ``matcher_type`` FLANN (v2's default), ORB descriptors are matched by v2's own brute
    force: each frame keypoint to its nearest node keypoint when they differ in fewer than
    half the bits, scored by that distance over the descriptor's bits. Otherwise, and for
    every other descriptor, by the ratio test (a node keypoint matched once), scored by the ratio.
    """
    query, train = frame.descriptors, node.descriptors
    if params.matcher_type == "FLANN" and params.feature_detector_type == "ORB":
        bits = 8 * frame.features.descriptors.shape[1]
        frame_index, node_index, distance = hamming_nearest_matches(query, train, bits // 2)
        score = distance / bits
    elif frame.features.binary:
        frame_index, node_index, score = hamming_ratio_matches(query, train, params.nn_distance_ratio)
    else:
        frame_index, node_index, score = match_with_ratios(
            frame.features.descriptors, node.features.descriptors, False, params.nn_distance_ratio
        )
    order = np.argsort(score + SORT_JITTER * rng.random(len(score)), kind="stable")[: params.max_matches]
    return frame_index[order], node_index[order]


def estimate_motion(
    frame: MeasuredFeatures,
    node: MeasuredFeatures,
    matches: tuple[np.ndarray, np.ndarray],
    params: RgbdSlamParams,
    rng: np.random.Generator,
    min_inlier_ratio: float = 0.0,
) -> tuple[Motion | None, str]:
    """The node-from-frame transform, or None with the reason ('' on success).

    As v2: more than ``min_matches`` matches, then at least ``min_matches`` inliers (three
    quarters of the matches when that is less). ``min_inlier_ratio`` > 0 (ours, off by
    default) also asks for that share of the matches as inliers.
    """
    frame_index, node_index = matches
    if len(frame_index) <= params.min_matches:
        return None, f"too few matches ({len(frame_index)} <= {params.min_matches})"
    result = ransac_rigid(
        frame.features.points[frame_index],
        node.features.points[node_index],
        iterations=params.ransac_iterations,
        max_mahalanobis=params.max_dist_for_inliers,
        min_inliers=params.min_matches,
        sigma_depth=params.sigma_depth,
        rng=rng,
    )
    if result is None:
        return None, "RANSAC found no transformation with enough inliers"
    inliers = result.inlier_count
    if inliers < min_inlier_ratio * len(frame_index):
        return None, f"too few of the matches are inliers ({inliers} of {len(frame_index)}, < {min_inlier_ratio:g})"
    return Motion(
        result.transform,
        frame_index,
        node_index,
        result.inliers,
        result.rms_mahalanobis,
        edge_information(inliers, result.rms_mahalanobis),
    ), ""


def motion_size(node_from_frame: np.ndarray) -> tuple[float, float]:
    """A motion's translation in metres and rotation in degrees (v2's ``trafoSize``)."""
    return (float(np.linalg.norm(node_from_frame[:3, 3])), float(np.degrees(rotation_angle(node_from_frame[:3, :3]))))


def moved_enough(node_from_frame: np.ndarray, params: RgbdSlamParams) -> bool:
    """v2's ``isBigTrafo``: at least min_translation_meter or min_rotation_degree."""
    metres, degrees = motion_size(node_from_frame)
    return metres >= params.min_translation_meter or degrees >= params.min_rotation_degree


def smooth_enough(node_from_frame: np.ndarray, gap_s: float, params: RgbdSlamParams) -> bool:
    """v2's ``isSmallTrafo``: a motion between two frames ``gap_s`` seconds apart moves less than
    max_translation_meter and turns less than max_rotation_degree per second (a gap of zero or
    less is not tested). At v2's defaults (1e10 m/s, 360 deg/s) it refuses a match that turns a
    camera by more than 12 degrees from one frame to the next at 30 Hz."""
    if gap_s <= 0:
        return True
    metres, degrees = motion_size(node_from_frame)
    return metres / gap_s < params.max_translation_meter and degrees / gap_s < params.max_rotation_degree


def too_fast_reason(node_from_frame: np.ndarray, gap_s: float, params: RgbdSlamParams) -> str:
    metres, degrees = motion_size(node_from_frame)
    return (
        f"motion too fast ({metres / gap_s:.3g} m/s, {degrees / gap_s:.3g} deg/s; max_translation_meter "
        f"{params.max_translation_meter:g}, max_rotation_degree {params.max_rotation_degree:g})"
    )
