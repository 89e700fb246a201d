"""Frame-to-node motion: descriptor matching, then 3D-3D RANSAC under the sensor noise model."""

from dataclasses import dataclass

import numpy as np

from ...frontend.features import Features, match_descriptors
from ...frontend.ransac import point_variances, ransac_rigid
from ...geometry.camera import Camera
from .params import RgbdSlamParams

# Floor on the residual used for edge information: exact synthetic data would otherwise
# give edges so certain that the optimiser could not move them at all.
MIN_RESIDUAL_M = 0.002


@dataclass
class MeasuredFeatures:
    """Keypoints that have a 3D point, with the per-axis variances of those points."""

    features: Features
    variances: np.ndarray

    @classmethod
    def from_features(cls, features: Features, params: RgbdSlamParams, camera: Camera) -> "MeasuredFeatures":
        usable = features.subset(features.has_depth)
        focal = 0.5 * (camera.fx + camera.fy)
        return cls(usable, point_variances(usable.points, params.keypoint_pixel_sigma, focal))

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
    rms_error: float
    information: np.ndarray

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())


def edge_information(points: np.ndarray, rms_error: float) -> np.ndarray:
    """Information of a transform fitted to ``points`` (its inliers) with RMS residual
    ``rms_error``: translation known to residual/sqrt(n), rotation to that over the points' spread."""
    count = len(points)
    variance = max(rms_error, MIN_RESIDUAL_M) ** 2
    spread = np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))
    return np.diag([count * spread / variance] * 3 + [count / variance] * 3)


def match(frame: MeasuredFeatures, node: MeasuredFeatures, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    return match_descriptors(frame.features.descriptors, node.features.descriptors, frame.features.binary, ratio)


def estimate_motion(frame: MeasuredFeatures, node: MeasuredFeatures, matches: tuple[np.ndarray, np.ndarray],
                    params: RgbdSlamParams, rng: np.random.Generator,
                    min_inlier_ratio: float = 0.0) -> tuple[Motion | None, str]:
    """The node-from-frame transform if at least ``min_matches`` inliers, and that share of
    the matches, support it, else None; with the reason for a rejection ('' on success)."""
    frame_index, node_index = matches
    if len(frame_index) < params.min_matches:
        return None, f"too few matches ({len(frame_index)} < {params.min_matches})"
    result = ransac_rigid(frame.features.points[frame_index], node.features.points[node_index],
                          frame.variances[frame_index], node.variances[node_index],
                          iterations=params.ransac_iterations, max_mahalanobis=params.max_dist_for_inliers,
                          rng=rng)
    inliers = 0 if result is None else result.inlier_count
    if inliers < params.min_matches:
        return None, f"too few inliers ({inliers} < {params.min_matches})"
    if inliers < min_inlier_ratio * len(frame_index):
        return None, f"too few of the matches are inliers ({inliers} of {len(frame_index)}, < {min_inlier_ratio:g})"
    information = edge_information(node.features.points[node_index[result.inliers]], result.rms_error)
    return Motion(result.transform, frame_index, node_index, result.inliers, result.rms_error, information), ""
