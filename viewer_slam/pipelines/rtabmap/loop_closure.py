"""Loop closure hypotheses: by appearance (tf-idf + Bayes filter) and by space, both
verified geometrically by PnP RANSAC between the two locations' features."""

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ...backend.local_bundle import Link as BundleLink
from ...backend.local_bundle import adjust_frame
from ...frontend.pnp import solve_pnp_ransac
from ...geometry.camera import Camera
from ...geometry.se3 import invert, transform_points
from .bayes import PREDICTION_MARGINS, BayesFilter, Hypothesis, adjusted_likelihood, highest_hypothesis
from .bundle import OLDER, two_view_observations
from .correspondences import TreeSeeds, word_matches
from .graph import Variance, registration_variance
from .memory import Link, Location, Memory
from .odometry import pinhole_pixels
from .params import RtabmapParams


@dataclass
class Detection:
    """One Bayes filter update: the hypothesis (None when no location has belief), how many
    states the posterior holds (virtual place included), and each candidate's likelihood."""

    hypothesis: Hypothesis | None
    states: int
    likelihood: dict[int, float]


@dataclass
class Registration:
    """``relative = T_old^-1 T_new``, or None with the reason it was rejected."""

    relative: np.ndarray | None
    matches: int
    inliers: int
    variance: Variance = Variance()
    rejected: str = ""


# RTAB-Map's robot frame (x forward, y left, z up) seen from the optical frame.
OPTICAL_TO_ROBOT = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
MAX_LOOP_ROTATION = np.pi / 2


def too_large_rotation(relative: np.ndarray) -> bool:
    """Memory::computeTransform's check: a loop closure turning the robot by more than 90
    degrees in pitch or yaw (Euler angles in its x-forward, z-up frame) is not believed."""
    in_robot = OPTICAL_TO_ROBOT @ relative[:3, :3] @ OPTICAL_TO_ROBOT.T
    yaw, pitch, _ = Rotation.from_matrix(in_robot).as_euler("ZYX")
    return abs(pitch) > MAX_LOOP_ROTATION or abs(yaw) > MAX_LOOP_ROTATION


def register(
    old: Location, new: Location, camera: Camera, params: RtabmapParams, tree_seeds: TreeSeeds
) -> Registration:
    """The new location's pose in the old one's frame from its keypoints and the old 3D words."""
    with_depth = np.flatnonzero(~np.isnan(old.points[:, 0]))
    matches = word_matches(
        new.descriptors,
        old.descriptors[with_depth],
        params.correspondence_nndr,
        params.correspondence_nn_type,
        tree_seeds,
    )
    query, train = matches.query, matches.train
    solution = solve_pnp_ransac(
        old.points[with_depth[train]],
        new.keypoints[query],
        camera.K,
        reprojection_error=params.pnp_inlier_distance,
        distortion=camera.distortion,
        iterations=params.ransac_iterations,
        min_inliers=params.min_inliers,
        refine_iterations=params.pnp_refine_iterations,
        refine_distance=params.pnp_reprojection_error,
    )
    if solution is None:
        return Registration(
            None,
            len(query),
            0,
            rejected=f"too few inliers (< Vis/MinInliers {params.min_inliers}) among {len(query)} matches",
        )
    pose, inliers = solution.pose, np.flatnonzero(solution.inliers)
    older_rows, newer_rows = with_depth[train[inliers]], query[inliers]
    variance = registration_variance(transform_points(invert(pose), old.points[older_rows]), new.points[newer_rows])
    inlier_count = len(inliers)
    if params.registration_bundle_adjustment:
        pose, inlier_count = two_view_adjusted(old, new, older_rows, newer_rows, pose, variance, camera, params)
        if inlier_count < params.min_inliers:
            return Registration(
                None,
                len(query),
                inlier_count,
                rejected=f"too few inliers after the bundle adjustment (< Vis/MinInliers {params.min_inliers})",
            )
    if too_large_rotation(pose):
        return Registration(None, len(query), inlier_count, rejected="rotation over 90 degrees")
    return Registration(pose, len(query), inlier_count, variance)


def two_view_adjusted(
    old: Location,
    new: Location,
    older_rows: np.ndarray,
    newer_rows: np.ndarray,
    pose: np.ndarray,
    variance: Variance,
    camera: Camera,
    params: RtabmapParams,
) -> tuple[np.ndarray, int]:
    """Vis/BundleAdjustment (``RegistrationVis::computeTransformationImpl``): the registration's
    pose refined with its inliers' 3D points, the older location fixed at the origin and the
    registration as the link between the two, its covariance unchanged; returned with the
    inliers that keep both observations."""
    points = old.points[older_rows]
    observations = two_view_observations(
        pinhole_pixels(camera, old.keypoints[older_rows]),
        points[:, 2],
        pinhole_pixels(camera, new.keypoints[newer_rows]),
        new.points[newer_rows, 2],
    )
    link = BundleLink(OLDER, pose, variance.translation, variance.rotation)
    adjusted = adjust_frame(pose, points, observations, {OLDER: np.eye(4)}, link, camera.K, params.bundle_settings)
    return adjusted.pose, int((~adjusted.outliers).sum())


class AppearanceDetector:
    """tf-idf likelihood over the WM locations fed to the Bayes filter."""

    def __init__(self):
        self.filter = BayesFilter()

    def detect(self, memory: Memory, words: np.ndarray) -> Detection | None:
        """The Bayes filter's update for a location with ``words``; None while WM is empty."""
        candidates = list(memory.wm)
        if not candidates:
            return None
        location_likelihood, virtual_likelihood = adjusted_likelihood(memory.vocabulary.scores(words, candidates))
        stm = set(memory.stm)

        def neighbours(location: int) -> dict[int, int]:
            # BayesFilter::generatePrediction: neighbours in STM/WM, loop links on the same margin.
            margins = memory.neighbours(location, PREDICTION_MARGINS)
            return {i: m for i, m in margins.items() if i not in stm}

        posterior = self.filter.update(candidates, neighbours, location_likelihood, virtual_likelihood)
        return Detection(
            highest_hypothesis(posterior), len(posterior), dict(zip(candidates, location_likelihood.tolist()))
        )


def nearby_locations(
    memory: Memory, poses: dict[int, np.ndarray], location: int, same_map, params: RtabmapParams
) -> set[int]:
    """Memory::getNeighborsIdRadius: the locations of ``location``'s map within RGBD/LocalRadius
    of it and at most RGBD/ProximityMaxGraphDepth links from it, STM included."""
    here = poses[location][:3, 3]
    depth = memory.neighbours(location, params.proximity_max_graph_depth, loops_add_margin=True, follow_proximity=True)
    return {
        i
        for i in depth
        if i != location and same_map(i) and np.linalg.norm(poses[i][:3, 3] - here) < params.local_radius
    }


def proximity_paths(
    memory: Memory, poses: dict[int, np.ndarray], location: int, candidates: set[int], max_graph_depth: int
) -> dict[int, list[int]]:
    """Rtabmap::getPaths: the candidates cut into paths, each keyed by the candidate nearest
    the camera that starts it. From the nearest remaining candidate, its neighbours by
    odometry links within ``max_graph_depth``, through candidates only, in id order, each
    joining the path when it is linked to one already in it; so a long chain of candidates
    makes several paths, at most ``2 * max_graph_depth - 1`` locations each."""
    here = poses[location][:3, 3]
    remaining = set(candidates)
    paths: dict[int, list[int]] = {}
    while remaining:
        nearest = min(sorted(remaining), key=lambda i: float(np.linalg.norm(poses[i][:3, 3] - here)))
        reached = memory.neighbours(nearest, max_graph_depth, follow_loops=False, within=candidates)
        path_set: set[int] = set()
        path: list[int] = []
        for i in sorted(reached):
            linked = (j for j, kind in memory.locations[i].links.items() if kind is Link.NEIGHBOUR)
            if i in remaining and (not path or any(j in path_set for j in linked)):
                path.append(i)
                path_set.add(i)
                remaining.discard(i)
        paths[nearest] = path
    return paths


def proximity_candidates(
    memory: Memory,
    poses: dict[int, np.ndarray],
    location: int,
    nearby: set[int],
    likelihood: dict[int, float],
    params: RtabmapParams,
) -> list[int]:
    """Rtabmap::process, proximity detection by space (RTAB-Map 0.23.8): one location per path
    to register with.

    Candidates are the ``nearby`` locations (:func:`nearby_locations`) off STM, cut into
    :func:`proximity_paths`. Paths are compared from the one of highest likelihood (the highest
    any of its locations holds; among equals the one whose nearest location has the higher id)
    for at most RGBD/ProximityMaxPaths paths: ``NearestPathKey(highest likelihood, nearest id)``.
    Of a path's locations looking within RGBD/ProximityAngle of the camera, the nearest is
    proposed (its key's location when that one faces the camera, else the nearest of those
    that do); it must lie within RGBD/ProximityPathFilteringRadius and not be linked to
    ``location`` already.
    """
    here = poses[location]
    paths = proximity_paths(memory, poses, location, nearby - set(memory.stm), params.proximity_max_graph_depth)
    ranked = sorted(
        (
            ((max((likelihood.get(i, 0.0) for i in path), default=0.0), nearest), path)
            for nearest, path in paths.items()
        ),
        key=lambda ranked_path: ranked_path[0],
        reverse=True,
    )
    if params.proximity_max_paths > 0:
        ranked = ranked[: params.proximity_max_paths]
    chosen = []
    for _, path in ranked:
        facing = [i for i in path if view_angle(poses[i], here) <= params.proximity_angle]
        if not facing:
            continue
        best = min(facing, key=lambda i: float(np.linalg.norm(poses[i][:3, 3] - here[:3, 3])))
        if (
            within_filtering_radius(poses[best][:3, 3] - here[:3, 3], params)
            and best not in memory.locations[location].links
        ):
            chosen.append(best)
    return chosen


def within_filtering_radius(translation: np.ndarray, params: RtabmapParams) -> bool:
    """RGBD/ProximityPathFilteringRadius (0: no limit): how far a proximity candidate, and the
    registration that links it, may reach."""
    radius = params.proximity_filtering_radius
    return radius <= 0 or float(np.linalg.norm(translation)) < radius


def view_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Degrees between two cameras' viewing directions (optical axes)."""
    return float(np.degrees(np.arccos(np.clip(a[:3, 2] @ b[:3, 2], -1.0, 1.0))))
