"""RTAB-Map's parameters, under RTAB-Map's own names and with its defaults."""

from typing import Annotated, ClassVar, Literal

from pydantic import Field, ValidationInfo, model_validator

from ...backend.local_bundle import BundleSettings
from ..params import EXACT_INT, PipelineParams, check_ordered


class RtabmapParams(PipelineParams):
    # Features (shared by odometry and the vocabulary).
    detector_strategy: Annotated[Literal[6, 8], EXACT_INT] = Field(
        8, alias="Kp/DetectorStrategy", description="6: GFTT corners with BRIEF descriptors, 8: GFTT with ORB"
    )
    # Frame-to-map visual odometry.
    odometry_max_features: int = Field(
        1000, alias="Vis/MaxFeatures", gt=0, description="features extracted per frame for odometry"
    )
    correspondence_nndr: float = Field(
        0.8, alias="Vis/CorNNDR", gt=0, le=1, description="nearest-neighbour distance ratio of a match"
    )
    correspondence_nn_type: Annotated[Literal[1, 3], EXACT_INT] = Field(
        1,
        alias="Vis/CorNNType",
        description="nearest words without a motion guess: 1 FLANN's randomised k-d trees (approximate), 3 brute "
        "force (exact)",
    )
    guess_window: int = Field(
        40,
        alias="Vis/CorGuessWinSize",
        ge=0,
        description="radius (px) around a map point's predicted projection searched for its "
        "match (0: no guided matching)",
    )
    guess_match_to_projection: bool = Field(
        False,
        alias="Vis/CorGuessMatchToProjection",
        description="with a motion guess, match each corner to the projected "
        "map points instead of each projected map point to the "
        "corners",
    )
    pnp_reprojection_error: float = Field(
        2.0,
        alias="Vis/PnPReprojError",
        gt=0,
        description="PnP RANSAC threshold: a match reprojected within its square (px) is an "
        "inlier, as RTAB-Map's RANSAC compares",
    )
    pnp_refine_iterations: int = Field(
        0,
        alias="Vis/PnPRefineIterations",
        ge=0,
        description="refinements of PnP RANSAC's pose on its inliers (RTAB-Map built "
        "with g2o, as the study ran it: 0, the bundle adjustments refine instead; without g2o: 1)",
    )
    registration_bundle_adjustment: Annotated[Literal[0, 1], EXACT_INT] = Field(
        1,
        alias="Vis/BundleAdjustment",
        description="two-view bundle adjustment of each loop closure and proximity registration "
        "(0: off, 1: g2o's algorithm)",
    )
    min_inliers: int = Field(20, alias="Vis/MinInliers", ge=4, description="inliers needed to accept a registration")
    ransac_iterations: int = Field(300, alias="Vis/Iterations", ge=1, description="PnP RANSAC iterations")
    repeat_once: bool = Field(
        True,
        alias="Reg/RepeatOnce",
        description="redo a registration made without a motion guess with its result as the guess",
    )
    local_map_size: int = Field(
        2000, alias="OdomF2M/MaxSize", gt=0, description="most 3D features kept in the odometry local map"
    )
    keyframe_threshold: float = Field(
        0.3,
        alias="Odom/KeyFrameThr",
        ge=0,
        le=1,
        description="update the local map when inliers / features falls to this",
    )
    keyframe_inliers: int = Field(
        150, alias="Odom/VisKeyFrameThr", ge=0, description="update the local map when the inliers fall to this many"
    )
    min_depth: float = Field(
        0.0, alias="Vis/MinDepth", ge=0, description="nearest depth (m) a feature may have (0: no limit)"
    )
    max_depth: float = Field(
        0.0, alias="Vis/MaxDepth", ge=0, description="farthest depth (m) a feature may have (0: no limit)"
    )
    depth_as_mask: bool = Field(
        True, alias="Vis/DepthAsMask", description="detect features only where the depth is valid"
    )
    bundle_adjustment: Annotated[Literal[0, 1], EXACT_INT] = Field(
        1,
        alias="OdomF2M/BundleAdjustment",
        description="local bundle adjustment of each registration (0: off, 1: g2o's algorithm)",
    )
    bundle_max_frames: int = Field(
        10,
        alias="OdomF2M/BundleAdjustmentMaxFrames",
        ge=0,
        description="key frames a map point's observations are sampled from (0: all)",
    )
    bundle_pixel_variance: float = Field(
        1.0, alias="g2o/PixelVariance", gt=0, description="pixel variance of the bundle adjustment's observations"
    )
    bundle_kernel_delta: float = Field(
        8.0,
        alias="g2o/RobustKernelDelta",
        ge=0,
        description="Huber delta; observations with chi2 over it are dropped (0: no kernel)",
    )
    bundle_baseline: float = Field(
        0.075,
        alias="g2o/Baseline",
        ge=0,
        description="fake stereo baseline (m) that weighs the depth in the bundle (0: mono)",
    )
    reset_countdown: int = Field(
        0, alias="Odom/ResetCountdown", ge=0, description="reset odometry after this many lost frames (0: never)"
    )
    new_map_on_loss: bool = Field(
        False,
        alias="viewslam/NewMapOnLoss",
        description="viewslam's option, as the rtabmap-rgbd_dataset tool does (not the "
        "library): start a new map with the first location after odometry was "
        "lost",
    )
    link_covariance: Literal["largest", "own"] = Field(
        "largest",
        alias="viewslam/LinkCovariance",
        description="viewslam's name for how the front-end the original ran in sets a location's odometry "
        "link covariance: 'largest', that of the registration with the largest translation variance "
        "since the previous location (rtabmap_ros and RtabmapThread, 'to be independent of the "
        "odometry frame rate'), or 'own', the location frame's registration alone (the "
        "rtabmap-rgbd_dataset tool)",
    )
    # Locations.
    detection_rate: float = Field(
        1.0, alias="Rtabmap/DetectionRate", ge=0, description="locations per second at most (0: every frame)"
    )
    linear_update: float = Field(0.1, alias="RGBD/LinearUpdate", ge=0, description="metres moved before a new location")
    angular_update: float = Field(
        0.1, alias="RGBD/AngularUpdate", ge=0, description="radians turned before a new location"
    )
    # Loop closure detection.
    words_per_location: int = Field(
        500, alias="Kp/MaxFeatures", gt=0, description="visual words extracted per location"
    )
    word_nndr: float = Field(
        0.8, alias="Kp/NndrRatio", gt=0, le=1, description="ratio test quantising a descriptor to a word"
    )
    bad_signature_ratio: float = Field(
        0.5,
        alias="Kp/BadSignRatio",
        ge=0,
        description="a location with fewer words than this share of the mean is left out of detection",
    )
    loop_threshold: float = Field(
        0.11, alias="Rtabmap/LoopThr", ge=0, le=1, description="posterior a loop hypothesis must exceed"
    )
    aggressive_loop_threshold: float = Field(
        0.05,
        alias="RGBD/AggressiveLoopThr",
        ge=0,
        le=1,
        description="Rtabmap/LoopThr's place for a hypothesis in a map not joined to the current one",
    )
    loop_ratio: float = Field(
        0.0, alias="Rtabmap/LoopRatio", ge=0, description="a hypothesis must also exceed this ratio of the previous one"
    )
    proximity_by_space: bool = Field(
        True, alias="RGBD/ProximityBySpace", description="also link to nearby locations of the graph"
    )
    local_radius: float = Field(10.0, alias="RGBD/LocalRadius", ge=0, description="radius (m) of the proximity search")
    proximity_angle: float = Field(
        45.0,
        alias="RGBD/ProximityAngle",
        ge=0,
        le=180,
        description="largest view-direction difference (deg) of a proximity link",
    )
    proximity_max_graph_depth: int = Field(
        50,
        alias="RGBD/ProximityMaxGraphDepth",
        ge=0,
        description="most links between the location and a proximity candidate (0: any)",
    )
    proximity_max_paths: int = Field(
        3,
        alias="RGBD/ProximityMaxPaths",
        ge=0,
        description="most paths of nearby locations compared per update (0: all)",
    )
    proximity_filtering_radius: float = Field(
        1.0,
        alias="RGBD/ProximityPathFilteringRadius",
        ge=0,
        description="a path's nearest location must be this close (m) to be compared",
    )
    # Memory management.
    stm_size: int = Field(
        10, alias="Mem/STMSize", ge=0, description="newest locations kept out of loop closure detection"
    )
    rehearsal_similarity: float = Field(
        0.6,
        alias="Mem/RehearsalSimilarity",
        ge=0,
        le=1,
        description="word similarity above which a location is rehearsed",
    )
    recent_wm_ratio: float = Field(
        0.2,
        alias="Mem/RecentWmRatio",
        ge=0,
        le=1,
        description="share of WM, after the last loop closure, that cannot be transferred",
    )
    local_immunization_ratio: float = Field(
        0.25,
        alias="RGBD/LocalImmunizationRatio",
        ge=0,
        le=1,
        description="share of WM near the camera kept from transfer",
    )
    time_threshold: float = Field(
        0.0,
        alias="Rtabmap/TimeThr",
        ge=0,
        description="ms per location update above which (added + 1) locations go to LTM (0: off)",
    )
    memory_threshold: int = Field(
        0, alias="Rtabmap/MemoryThr", ge=0, description="most locations in Working Memory (0: off)"
    )
    max_retrieved: int = Field(
        2, alias="Rtabmap/MaxRetrieved", ge=0, description="locations brought back from LTM per update"
    )
    # Graph optimisation.
    optimizer_iterations: int = Field(
        20, alias="Optimizer/Iterations", ge=1, description="GTSAM Levenberg-Marquardt iterations"
    )
    optimize_max_error: float = Field(
        3.0,
        alias="RGBD/OptimizeMaxError",
        ge=0,
        description="reject a closure whose link errors exceed this many sigmas (0: off)",
    )

    TRACKING_MINIMUM: ClassVar[str | None] = "min_inliers"

    @model_validator(mode="after")
    def depths_ordered(self, info: ValidationInfo) -> "RtabmapParams":
        return check_ordered(self, info, "min_depth", "max_depth", off=0.0)

    @property
    def pnp_inlier_distance(self) -> float:
        """The largest reprojection error (px) PnP RANSAC counts as an inlier: the square of
        Vis/PnPReprojError. RTAB-Map always calls the copy of OpenCV 3.0's solvePnPRansac it
        compiles in (``corelib/src/opencv/solvepnp.cpp``), whose error per point is the plain
        pixel distance while its inlier test compares it with the threshold squared, as if
        the error were squared too: at the default 2 px a match up to 4 px off is an inlier.
        Its refinement (Vis/PnPRefineIterations) reports RANSAC's inliers, so this is also the
        count the key-frame and Vis/MinInliers tests see."""
        return self.pnp_reprojection_error**2

    @property
    def bundle_settings(self) -> BundleSettings:
        """What both bundle adjustments solve with (g2o/*, Optimizer/Iterations)."""
        return BundleSettings(
            self.bundle_pixel_variance, self.bundle_kernel_delta, self.bundle_baseline, self.optimizer_iterations
        )

    @property
    def feature_kind(self) -> str:
        return {6: "GFTT_BRIEF", 8: "GFTT_ORB"}[self.detector_strategy]
