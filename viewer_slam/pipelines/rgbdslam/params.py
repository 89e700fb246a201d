"""RGB-D SLAM's parameters under RGB-D SLAM v2's names and with its defaults."""

from dataclasses import dataclass
from typing import ClassVar

from ...errors import InputError
from ...frontend.features import DETECTORS
from ..params import Ordered, param

SURF_MESSAGE = ("feature_detector_type SURF: SURF is patented and absent from the pip OpenCV builds; "
                f"choose one of {', '.join(DETECTORS)}")


@dataclass
class RgbdSlamParams:
    """Each default is RGB-D SLAM v2's (``parameter_server.cpp``) unless its help says otherwise;
    keys starting with ``viewslam_`` are ours, not v2's, and off by default."""

    feature_detector_type: str = param(
        "ORB", help="keypoint detector and descriptor (SURF is named for v2 compatibility and refused)",
        choices=(*DETECTORS, "SURF"))
    max_keypoints: int = param(600, gt=0, help="keypoints kept per frame")
    concurrent_node_construction: bool = param(
        True, help="extract the next frame's features on a thread of their own while this frame is compared and inserted")
    detector_grid_resolution: int = param(
        3, ge=1, help="the image is split into NxN cells, each detected with its own adjusted threshold (1 = no grid)")
    adjuster_max_iterations: int = param(
        5, ge=0, help="times a cell's detector threshold may be adapted when its keypoints are out of bounds (ORB, SIFT; 0 = fixed)")
    matcher_type: str = param(
        "FLANN", choices=("FLANN", "BRUTEFORCE_OPENCV"),
        help="descriptor matching: FLANN matches ORB by nearest neighbour within half the bits (v2's own brute "
        "force) and other descriptors by the ratio test; BRUTEFORCE_OPENCV matches ORB by the ratio test too")
    nn_distance_ratio: float = param(
        0.95, gt=0, le=1, help="ratio test: nearest descriptor distance must be below this times the second nearest")
    max_matches: int = param(300, ge=4, help="only the best matches (lowest distance or ratio) are kept for RANSAC")
    ransac_iterations: int = param(200, ge=1, help="four-point hypotheses per RANSAC run")
    max_dist_for_inliers: float = param(
        3.0, gt=0, help="Mahalanobis distance below which a correspondence is an inlier (sensor noise model)")
    sigma_depth: float = param(
        0.01, gt=0, help="factor c of the depth standard deviation c * z^2 in the inlier noise model")
    min_matches: int = param(20, ge=3, help="matches needed before RANSAC, and RANSAC inliers needed to accept a transformation")
    predecessor_candidates: int = param(4, ge=1, help="most recent nodes compared with each frame")
    neighbor_candidates: int = param(
        4, ge=0, help="graph neighbours of the predecessor (within geodesic_depth) sampled, farther ids likelier")
    min_sampled_candidates: int = param(
        4, ge=0, help="keyframes sampled uniformly from the whole graph for each frame (loop closure, relocalisation)")
    geodesic_depth: int = param(3, ge=0, help="graph distance searched for neighbor_candidates")
    min_translation_meter: float = param(0.0, ge=0, help="translation from the newest node below which a frame is no new node")
    min_rotation_degree: float = param(0.0, ge=0, help="rotation from the newest node below which a frame is no new node")
    keep_all_nodes: bool = param(
        False, help="keep frames that match no node, under a no-motion (constant position) assumption")
    observability_threshold: float = param(
        -0.6, ge=-1, le=1, help="environment measurement model: minimum share of consistent depth (<= 0 = off)")
    emm_depth_tolerance: float = param(
        0.05, gt=0, help="ours: relative depth difference within which the EMM counts a point as consistent")
    optimizer_iterations: float = param(
        0.01, gt=0, help="online optimisation: iterations if >= 1, else stop when the error improves by less than this fraction")
    optimizer_skip_step: int = param(1, ge=1, help="optimise online after every N-th new node")
    backend_solver: str = param(
        "pcg", help="linear solver of each optimisation step: pcg (conjugate gradients, block-Jacobi preconditioner), "
        "or sparse Cholesky (cholmod, csparse: both GTSAM's)", choices=("pcg", "cholmod", "csparse"))
    maximum_depth: float = param(
        0.0, ge=0, help="keypoints farther than this (metres) get no 3D point (0 = no limit, v2's infinity)")
    minimum_depth: float = param(0.1, ge=0, help="keypoints nearer than this (metres) get no 3D point")
    viewslam_min_inlier_ratio: float = param(
        0.0, ge=0, le=1, help="ours: share of the matches that must be RANSAC inliers for a loop closure or relocalisation (0 = off)")
    viewslam_new_segment_after_lost_frames: int = param(
        0, ge=0, help="ours: after this many lost frames that match each other but not the map, start a new graph segment at the last pose (0 = off)")
    viewslam_optimization_spacing: float = param(
        0.0, ge=0, lt=1, help="ours: on a graph of N nodes optimise online at most every N times this many nodes (0 = off)")

    RELATIONS: ClassVar[tuple[Ordered, ...]] = (Ordered("minimum_depth", "maximum_depth", off=0.0),
                                                Ordered("min_matches", "max_matches", strict=False))

    def __post_init__(self):
        if self.feature_detector_type == "SURF":
            raise InputError(SURF_MESSAGE)
