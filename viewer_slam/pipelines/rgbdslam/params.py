"""RGB-D SLAM's parameters under RGB-D SLAM v2's names, with its defaults where it has them."""

from dataclasses import dataclass

from ...errors import InputError
from ...frontend.features import DETECTORS
from ..params import param

SURF_MESSAGE = ("feature_detector_type SURF: SURF is patented and absent from the pip OpenCV builds; "
                f"choose one of {', '.join(DETECTORS)}")


@dataclass
class RgbdSlamParams:
    feature_detector_type: str = param(
        "ORB", help="keypoint detector and descriptor (SURF is named for v2 compatibility and refused)",
        choices=(*DETECTORS, "SURF"))
    max_keypoints: int = param(600, gt=0, help="keypoints kept per frame, strongest first, spread over the grid")
    detector_grid_resolution: int = param(
        3, ge=1, help="the image is split into NxN cells that share the keypoint budget (1 = no grid)")
    adjuster_max_iterations: int = param(
        5, ge=0, help="times the detector threshold may be lowered on a frame with fewer than max_keypoints (ORB, SIFT; 0 = fixed)")
    nn_distance_ratio: float = param(
        0.9, gt=0, le=1, help="ratio test: nearest descriptor distance must be below this times the second nearest")
    ransac_iterations: int = param(200, ge=1, help="three-point hypotheses per RANSAC run")
    max_dist_for_inliers: float = param(
        3.0, gt=0, help="Mahalanobis distance below which a correspondence is an inlier (sensor noise model)")
    keypoint_pixel_sigma: float = param(
        3.0, gt=0, help="pixel standard deviation of a keypoint position in the inlier noise model")
    min_matches: int = param(20, ge=3, help="RANSAC inliers needed to accept a transformation")
    min_inlier_ratio: float = param(
        0.3, ge=0, le=1, help="share of the matches that must be RANSAC inliers to accept a loop closure or relocalisation (0 = no minimum)")
    predecessor_candidates: int = param(4, ge=1, help="most recent nodes compared with each frame")
    neighbor_candidates: int = param(
        4, ge=0, help="graph neighbours of the last node (within geodesic_depth) compared with each new node")
    min_sampled_candidates: int = param(
        4, ge=0, help="nodes sampled from the whole graph for each new node and each lost frame (loop closure)")
    geodesic_depth: int = param(3, ge=0, help="graph distance searched for neighbor_candidates")
    min_translation_meter: float = param(0.05, ge=0, help="translation from its node that makes a frame a new node")
    min_rotation_degree: float = param(2.5, ge=0, help="rotation from its node that makes a frame a new node")
    observability_threshold: float = param(
        0.0, ge=0, le=1, help="environment measurement model: minimum share of consistent depth (0 = off)")
    emm_depth_tolerance: float = param(
        0.05, gt=0, help="relative depth difference within which the EMM counts a point as consistent")
    optimizer_iterations: int = param(
        10, ge=1, help="Levenberg-Marquardt iterations of each online optimisation (the final one runs to convergence)")
    optimizer_skip_step: int = param(
        1, ge=1, help="optimise online after every N-th new node (at least every 5 % of the graph size)")
    maximum_depth: float = param(6.0, gt=0, help="keypoints farther than this (metres) get no 3D point")
    minimum_depth: float = param(0.3, ge=0, help="keypoints nearer than this (metres) get no 3D point")
    segment_after_lost_frames: int = param(
        3, ge=1, help="consecutive lost frames that match each other but not the map before a new graph segment starts")

    def __post_init__(self):
        if self.feature_detector_type == "SURF":
            raise InputError(SURF_MESSAGE)
