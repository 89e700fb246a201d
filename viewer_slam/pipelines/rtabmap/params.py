"""RTAB-Map's parameters, under RTAB-Map's own names and with its defaults."""

from dataclasses import dataclass
from typing import ClassVar

from ..params import Ordered, param


@dataclass
class RtabmapParams:
    # Features (shared by odometry and the vocabulary).
    detector_strategy: int = param(8, key="Kp/DetectorStrategy", choices=(6, 8),
                                   help="6: GFTT corners with BRIEF descriptors, 8: GFTT with ORB")
    # Frame-to-map visual odometry.
    odometry_max_features: int = param(1000, gt=0, key="Vis/MaxFeatures", help="features extracted per frame for odometry")
    correspondence_nndr: float = param(0.8, gt=0, le=1, key="Vis/CorNNDR", help="nearest-neighbour distance ratio of a match")
    guess_window: int = param(40, ge=0, key="Vis/CorGuessWinSize",
                              help="radius (px) around a map point's predicted projection searched for its match "
                                   "(0: no guided matching)")
    guess_match_to_projection: bool = param(False, key="Vis/CorGuessMatchToProjection",
                                            help="with a motion guess, match each corner to the projected map points "
                                                 "instead of each projected map point to the corners")
    pnp_reprojection_error: float = param(2.0, gt=0, key="Vis/PnPReprojError", help="PnP RANSAC inlier threshold (px)")
    min_inliers: int = param(20, ge=4, key="Vis/MinInliers", help="inliers needed to accept a registration")
    ransac_iterations: int = param(300, ge=1, key="Vis/Iterations", help="PnP RANSAC iterations")
    repeat_once: bool = param(True, key="Reg/RepeatOnce",
                              help="redo a registration made without a motion guess with its result as the guess")
    local_map_size: int = param(2000, gt=0, key="OdomF2M/MaxSize", help="most 3D features kept in the odometry local map")
    keyframe_threshold: float = param(0.3, ge=0, le=1, key="Odom/KeyFrameThr",
                                      help="update the local map when inliers / features falls to this")
    keyframe_inliers: int = param(150, ge=0, key="Odom/VisKeyFrameThr",
                                  help="update the local map when the inliers fall to this many")
    min_depth: float = param(0.0, ge=0, key="Vis/MinDepth", help="nearest depth (m) a feature may have (0: no limit)")
    max_depth: float = param(0.0, ge=0, key="Vis/MaxDepth", help="farthest depth (m) a feature may have (0: no limit)")
    depth_as_mask: bool = param(True, key="Vis/DepthAsMask", help="detect features only where the depth is valid")
    bundle_adjustment: int = param(1, key="OdomF2M/BundleAdjustment", choices=(0, 1),
                                   help="local bundle adjustment of each registration (0: off, 1: g2o's algorithm)")
    bundle_max_frames: int = param(10, ge=0, key="OdomF2M/BundleAdjustmentMaxFrames",
                                   help="key frames a map point's observations are sampled from (0: all)")
    bundle_pixel_variance: float = param(1.0, gt=0, key="g2o/PixelVariance",
                                         help="pixel variance of the bundle adjustment's observations")
    bundle_kernel_delta: float = param(8.0, ge=0, key="g2o/RobustKernelDelta",
                                       help="Huber delta; observations with chi2 over it are dropped (0: no kernel)")
    bundle_baseline: float = param(0.075, ge=0, key="g2o/Baseline",
                                   help="fake stereo baseline (m) that weighs the depth in the bundle (0: mono)")
    reset_countdown: int = param(0, ge=0, key="Odom/ResetCountdown",
                                 help="reset odometry after this many lost frames (0: never)")
    new_map_on_loss: bool = param(False, key="viewslam/NewMapOnLoss",
                                  help="viewslam's option, as the rtabmap-rgbd_dataset tool does (not the library): "
                                       "start a new map with the first location after odometry was lost")
    # Locations.
    detection_rate: float = param(1.0, ge=0, key="Rtabmap/DetectionRate",
                                  help="locations per second at most (0: every frame)")
    linear_update: float = param(0.1, ge=0, key="RGBD/LinearUpdate", help="metres moved before a new location")
    angular_update: float = param(0.1, ge=0, key="RGBD/AngularUpdate", help="radians turned before a new location")
    # Loop closure detection.
    words_per_location: int = param(500, gt=0, key="Kp/MaxFeatures", help="visual words extracted per location")
    word_nndr: float = param(0.8, gt=0, le=1, key="Kp/NndrRatio", help="ratio test quantising a descriptor to a word")
    bad_signature_ratio: float = param(0.5, ge=0, key="Kp/BadSignRatio",
                                       help="a location with fewer words than this share of the mean is left out of detection")
    loop_threshold: float = param(0.11, ge=0, le=1, key="Rtabmap/LoopThr", help="posterior a loop hypothesis must exceed")
    loop_ratio: float = param(0.0, ge=0, key="Rtabmap/LoopRatio",
                              help="a hypothesis must also exceed this ratio of the previous one")
    proximity_by_space: bool = param(True, key="RGBD/ProximityBySpace",
                                     help="also link to nearby locations of the graph")
    local_radius: float = param(10.0, ge=0, key="RGBD/LocalRadius", help="radius (m) of the proximity search")
    proximity_angle: float = param(45.0, ge=0, le=180, key="RGBD/ProximityAngle",
                                   help="largest view-direction difference (deg) of a proximity link")
    proximity_max_graph_depth: int = param(50, ge=0, key="RGBD/ProximityMaxGraphDepth",
                                           help="most links between the location and a proximity candidate (0: any)")
    proximity_max_paths: int = param(3, ge=0, key="RGBD/ProximityMaxPaths",
                                     help="most paths of nearby locations compared per update (0: all)")
    proximity_filtering_radius: float = param(1.0, ge=0, key="RGBD/ProximityPathFilteringRadius",
                                              help="a path's nearest location must be this close (m) to be compared")
    # Memory management.
    stm_size: int = param(10, ge=0, key="Mem/STMSize", help="newest locations kept out of loop closure detection")
    rehearsal_similarity: float = param(0.6, ge=0, le=1, key="Mem/RehearsalSimilarity",
                                        help="word similarity above which a location is rehearsed")
    recent_wm_ratio: float = param(0.2, ge=0, le=1, key="Mem/RecentWmRatio",
                                   help="share of WM, after the last loop closure, that cannot be transferred")
    local_immunization_ratio: float = param(0.25, ge=0, le=1, key="RGBD/LocalImmunizationRatio",
                                            help="share of WM near the camera kept from transfer")
    time_threshold: float = param(0.0, ge=0, key="Rtabmap/TimeThr",
                                  help="ms per location update above which (added + 1) locations go to LTM (0: off)")
    memory_threshold: int = param(0, ge=0, key="Rtabmap/MemoryThr", help="most locations in Working Memory (0: off)")
    max_retrieved: int = param(2, ge=0, key="Rtabmap/MaxRetrieved", help="locations brought back from LTM per update")
    # Graph optimisation.
    optimizer_iterations: int = param(20, ge=1, key="Optimizer/Iterations", help="GTSAM Levenberg-Marquardt iterations")
    optimize_max_error: float = param(3.0, ge=0, key="RGBD/OptimizeMaxError",
                                      help="reject a closure whose link errors exceed this many sigmas (0: off)")

    RELATIONS: ClassVar[tuple[Ordered, ...]] = (Ordered("min_depth", "max_depth", off=0.0),)

    @property
    def feature_kind(self) -> str:
        return {6: "GFTT_BRIEF", 8: "GFTT_ORB"}[self.detector_strategy]
