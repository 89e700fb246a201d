"""Loop closure hypotheses: by appearance (tf-idf + Bayes filter) and by space, both
verified geometrically by PnP RANSAC between the two locations' features."""

from dataclasses import dataclass

import numpy as np

from ...frontend.features import match_descriptors
from ...frontend.pnp import solve_pnp_ransac
from ...geometry.camera import Camera
from ...geometry.se3 import invert, transform_points
from .bayes import NEW_PLACE, BayesFilter, likelihood
from .graph import registration_variance
from .memory import Location, Memory
from .params import RtabmapParams


@dataclass
class Hypothesis:
    """The WM location the Bayes filter believes most is being revisited."""

    location: int
    posterior: float
    new_place_posterior: float


@dataclass
class Registration:
    """``relative = T_old^-1 T_new``, or None when too few inliers agreed."""

    relative: np.ndarray | None
    matches: int
    inliers: int
    variance: float = 0.0


def register(old: Location, new: Location, camera: Camera, params: RtabmapParams, seed: int) -> Registration:
    """The new location's pose in the old one's frame from its keypoints and the old 3D words."""
    with_depth = np.flatnonzero(~np.isnan(old.points[:, 0]))
    query, train = match_descriptors(new.descriptors, old.descriptors[with_depth], True, params.correspondence_nndr)
    solution = solve_pnp_ransac(old.points[with_depth[train]], new.keypoints[query], camera.K,
                                reprojection_error=params.pnp_reprojection_error, distortion=camera.distortion,
                                iterations=params.ransac_iterations, min_inliers=params.min_inliers, seed=seed)
    if solution is None:
        return Registration(None, len(query), 0)
    old_points = old.points[with_depth[train[solution.inliers]]]
    new_points = transform_points(solution.pose, new.points[query[solution.inliers]])
    return Registration(solution.pose, len(query), solution.inlier_count, registration_variance(old_points, new_points))


class AppearanceDetector:
    """tf-idf likelihood over the WM locations fed to the Bayes filter."""

    def __init__(self):
        self.filter = BayesFilter()

    def detect(self, memory: Memory, words: np.ndarray, sessions: dict[int, int]) -> Hypothesis | None:
        """The best hypothesis for a location with ``words``; None while WM is empty.
        ``sessions`` maps locations to their odometry session (their chain in the graph)."""
        candidates = list(memory.wm)
        if not candidates:
            return None
        scores = memory.vocabulary.scores(words, candidates)
        location_likelihood, new_place_likelihood = likelihood(scores)
        ids = np.array(candidates)      # ids grow along each odometry chain: they are positions on it
        posterior = self.filter.update(candidates, ids, np.array([sessions[i] for i in candidates]),
                                       location_likelihood, new_place_likelihood)
        best = max(candidates, key=lambda i: (posterior[i], -i))
        return Hypothesis(best, posterior[best], posterior[NEW_PLACE])


def nearby_locations(memory: Memory, poses: dict[int, np.ndarray], location: int, same_map,
                     params: RtabmapParams) -> list[int]:
    """WM locations of the same map within RGBD/LocalRadius and RGBD/ProximityAngle of
    ``location``, not already linked to it, nearest first."""
    candidates = [i for i in memory.wm if same_map(i) and i not in memory.locations[location].links]
    if not candidates:
        return []
    here = poses[location]
    relative = invert(here)[None] @ np.stack([poses[i] for i in candidates])
    distance = np.linalg.norm(relative[:, :3, 3], axis=1)
    # Angle between viewing directions (optical axes), as RTAB-Map's proximity angle.
    axes = np.stack([poses[i][:3, 2] for i in candidates])
    angle = np.degrees(np.arccos(np.clip(axes @ here[:3, 2], -1.0, 1.0)))
    close = (distance <= params.local_radius) & (angle <= params.proximity_angle)
    order = np.argsort(distance, kind="stable")
    return [candidates[i] for i in order if close[i]]
