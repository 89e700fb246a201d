"""RGB-D SLAM's parameters under RGB-D SLAM v2's names and with its defaults."""

from typing import ClassVar, Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from ...frontend.features import DETECTORS, Detector
from ..params import PipelineParams, check_ordered, invalid

SURF_MESSAGE = (
    "feature_detector_type SURF: SURF is patented and absent from the pip OpenCV builds; "
    f"choose one of {', '.join(DETECTORS)}"
)


class RgbdSlamParams(PipelineParams):
    """Each default is RGB-D SLAM v2's (``parameter_server.cpp``) unless its description says otherwise;
    keys starting with ``viewslam_`` are ours, not v2's, and off by default."""

    feature_detector_type: Literal[Detector, "SURF"] = Field(
        "ORB", description="keypoint detector and descriptor (SURF is named for v2 compatibility and refused)"
    )
    max_keypoints: int = Field(600, gt=0, description="keypoints kept per frame")
    concurrent_node_construction: bool = Field(
        True,
        description="extract the next frame's features on a thread of their "
        "own while this frame is compared and inserted",
    )
    detector_grid_resolution: int = Field(
        3,
        ge=1,
        description="the image is split into NxN cells, each detected with its own adjusted threshold (1 = no grid)",
    )
    adjuster_max_iterations: int = Field(
        5,
        ge=0,
        description="times a cell's detector threshold may be adapted when its "
        "keypoints are out of bounds (ORB, SIFT; 0 = fixed)",
    )
    matcher_type: Literal["FLANN", "BRUTEFORCE_OPENCV"] = Field(
        "FLANN",
        description="descriptor matching: FLANN matches ORB by nearest neighbour within half the bits (v2's own "
        "brute force) and other descriptors by the ratio test; BRUTEFORCE_OPENCV matches ORB by the "
        "ratio test too",
    )
    nn_distance_ratio: float = Field(
        0.95,
        gt=0,
        le=1,
        description="ratio test: nearest descriptor distance must be below this times the second nearest",
    )
    max_matches: int = Field(
        300, ge=4, description="only the best matches (lowest distance or ratio) are kept for RANSAC"
    )
    ransac_iterations: int = Field(200, ge=1, description="four-point hypotheses per RANSAC run")
    max_dist_for_inliers: float = Field(
        3.0, gt=0, description="Mahalanobis distance below which a correspondence is an inlier (sensor noise model)"
    )
    sigma_depth: float = Field(
        0.01, gt=0, description="factor c of the depth standard deviation c * z^2 in the inlier noise model"
    )
    min_matches: int = Field(
        20, ge=3, description="matches needed before RANSAC, and RANSAC inliers needed to accept a transformation"
    )
    predecessor_candidates: int = Field(4, ge=1, description="most recent nodes compared with each frame")
    neighbor_candidates: int = Field(
        4, ge=0, description="graph neighbours of the predecessor (within geodesic_depth) sampled, farther ids likelier"
    )
    min_sampled_candidates: int = Field(
        4,
        ge=0,
        description="keyframes sampled uniformly from the whole graph for each frame (loop closure, relocalisation)",
    )
    geodesic_depth: int = Field(3, ge=0, description="graph distance searched for neighbor_candidates")
    min_translation_meter: float = Field(
        0.0, ge=0, description="translation from the newest node below which a frame is no new node"
    )
    min_rotation_degree: float = Field(
        0.0, ge=0, description="rotation from the newest node below which a frame is no new node"
    )
    max_translation_meter: float = Field(
        1e10,
        gt=0,
        description="a match whose translation per second between the two "
        "frames' times reaches this is refused (v2's sanity check "
        "for smooth motion)",
    )
    max_rotation_degree: float = Field(
        360.0,
        gt=0,
        description="a match whose rotation in degrees per second between the "
        "two frames' times reaches this is refused (v2's sanity "
        "check for smooth motion)",
    )
    keep_all_nodes: bool = Field(
        False, description="keep frames that match no node, under a no-motion (constant position) assumption"
    )
    observability_threshold: float = Field(
        -0.6, ge=-1, le=1, description="environment measurement model: minimum share of consistent depth (<= 0 = off)"
    )
    emm_depth_tolerance: float = Field(
        0.05, gt=0, description="ours: relative depth difference within which the EMM counts a point as consistent"
    )
    optimizer_iterations: float = Field(
        0.01,
        gt=0,
        description="online optimisation: iterations if >= 1, else stop when the "
        "error improves by less than this fraction",
    )
    optimizer_skip_step: int = Field(1, ge=1, description="optimise online after every N-th new node")
    backend_solver: Literal["pcg", "cholmod", "csparse"] = Field(
        "pcg",
        description="linear solver of each optimisation step: pcg (conjugate gradients, block-Jacobi "
        "preconditioner), or sparse Cholesky (cholmod, csparse: both GTSAM's)",
    )
    maximum_depth: float = Field(
        0.0, ge=0, description="keypoints farther than this (metres) get no 3D point (0 = no limit, v2's infinity)"
    )
    minimum_depth: float = Field(0.1, ge=0, description="keypoints nearer than this (metres) get no 3D point")
    viewslam_min_inlier_ratio: float = Field(
        0.0,
        ge=0,
        le=1,
        description="ours: share of the matches that must be RANSAC inliers "
        "for a loop closure or relocalisation (0 = off)",
    )
    viewslam_new_segment_after_lost_frames: int = Field(
        0,
        ge=0,
        description="ours: after this many lost frames that match each other but not the map, start a new graph "
        "segment at the last pose (0 = off)",
    )
    viewslam_optimization_spacing: float = Field(
        0.0,
        ge=0,
        lt=1,
        description="ours: on a graph of N nodes optimise online at most every N times this many nodes (0 = off)",
    )

    TRACKING_MINIMUM: ClassVar[str | None] = "min_matches"

    @model_validator(mode="after")
    def depths_ordered(self, info: ValidationInfo) -> "RgbdSlamParams":
        return check_ordered(self, info, "minimum_depth", "maximum_depth", off=0.0)

    @model_validator(mode="after")
    def matches_ordered(self, info: ValidationInfo) -> "RgbdSlamParams":
        return check_ordered(self, info, "min_matches", "max_matches", strict=False)

    @field_validator("feature_detector_type")
    @classmethod
    def _no_surf(cls, value: str) -> str:
        if value == "SURF":
            raise invalid(SURF_MESSAGE)
        return value
