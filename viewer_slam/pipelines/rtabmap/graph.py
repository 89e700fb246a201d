"""The location graph: odometry links, loop closure links, map sessions, GTSAM.

Each odometry session (a new one starts when odometry resets) is its own chain anchored by
a prior at its first location. A loop closure between two sessions re-expresses the newer
one in the older one's frame and drops its anchor, joining the maps as RTAB-Map does in
multi-session mapping. A closure inside a map is kept only if, after optimisation, no link
disagrees with the graph by more than RGBD/OptimizeMaxError of its standard deviation.
"""

from dataclasses import dataclass

import numpy as np

from ...backend.pose_graph import Edge, PoseGraph, information_from_sigmas
from ...geometry.se3 import invert

# PCL's computeVariance: a Gaussian's variance from the median of squared distances.
MEDIAN_TO_VARIANCE = 2.1981
# Vis/PnPVarianceMedianRatio: the element at n / 4 of the sorted errors stands for the median,
# "to ignore very very far features" (util3d::estimateMotion3DTo2D).
VARIANCE_MEDIAN_RATIO = 4
MIN_LINK_SIGMA = 0.001  # floor of a link's standard deviation (m, and rad)
ANCHOR_SIGMA = 1e-4
ANCHOR_INFORMATION = information_from_sigmas(ANCHOR_SIGMA, ANCHOR_SIGMA)


@dataclass(frozen=True)
class Variance:
    """The diagonal of RTAB-Map's registration covariance: each translation axis (m²) and each
    rotation axis."""

    translation: float = 0.0
    rotation: float = 0.0

    def larger(self, other: "Variance") -> "Variance":
        """The one with the larger translation variance, as rtabmap_ros compares covariance(0, 0)."""
        return other if other.translation > self.translation else self


def registration_variance(reference: np.ndarray, measured: np.ndarray) -> Variance:
    """Variance of a registration as RTAB-Map estimates it (``util3d::estimateMotion3DTo2D``,
    after PCL's ``computeVariance``), from the inliers' reference 3D points and the registered
    camera's own 3D points, both in that camera's frame (NaN pairs skipped): MEDIAN_TO_VARIANCE
    times the squared distance between the two, for translation, and times the angle between
    them seen from the camera (in radians, not squared, as there), for rotation, each the
    element at n / VARIANCE_MEDIAN_RATIO of its sorted values."""
    valid = ~np.isnan(reference).any(axis=1) & ~np.isnan(measured).any(axis=1)
    reference, measured = reference[valid], measured[valid]
    if not len(reference):
        return Variance()
    squared = np.sort(np.sum((reference - measured) ** 2, axis=1))
    cosine = np.sum(reference * measured, axis=1) / (
        np.linalg.norm(reference, axis=1) * np.linalg.norm(measured, axis=1)
    )
    angles = np.sort(np.arccos(np.clip(cosine, -1.0, 1.0)))
    at = len(reference) // VARIANCE_MEDIAN_RATIO
    return Variance(MEDIAN_TO_VARIANCE * float(squared[at]), MEDIAN_TO_VARIANCE * float(angles[at]))


def link_information(variance: Variance) -> np.ndarray:
    """Information of a link: the inverse of its variances, each standard deviation at least
    MIN_LINK_SIGMA."""
    return information_from_sigmas(
        max(np.sqrt(variance.rotation), MIN_LINK_SIGMA), max(np.sqrt(variance.translation), MIN_LINK_SIGMA)
    )


@dataclass
class ClosureOutcome:
    """Whether a loop closure link was kept, why, and the graph error around the optimisation."""

    accepted: bool
    reason: str
    error_before: float = 0.0
    error_after: float = 0.0
    joined_maps: bool = False  # a link to another map: it moved that map, optimising nothing


class LocationGraph:
    """Locations as GTSAM pose nodes, their odometry, and which map each session belongs to."""

    def __init__(self, iterations: int, max_error: float):
        self.pose_graph = PoseGraph()
        self.iterations = iterations
        self.max_error = max_error
        self.odometry: dict[int, np.ndarray] = {}
        self.session: dict[int, int] = {}
        self.map_of_session: dict[int, int] = {}  # session -> the map (oldest session) it joined
        self.last_of_session: dict[int, int] = {}

    @property
    def poses(self) -> dict[int, np.ndarray]:
        return self.pose_graph.poses

    def correction(self, location: int) -> np.ndarray:
        """``T_map_odom`` of the location's session, as the optimised graph sees it there."""
        return self.poses[location] @ invert(self.odometry[location])

    def map_of(self, location: int) -> int:
        return self.map_of_session[self.session[location]]

    def add_location(self, location: int, session: int, odometry_pose: np.ndarray, variance: Variance) -> None:
        """Chain a location to the previous one of its session (or anchor a new session);
        ``variance`` is that of the odometry link from the previous location."""
        previous = self.last_of_session.get(session)
        self.odometry[location] = odometry_pose
        self.session[location] = session
        self.last_of_session[session] = location
        if previous is None:
            self.map_of_session[session] = session
            self.pose_graph.add_node(location, odometry_pose)
            self.pose_graph.add_prior(location, odometry_pose, ANCHOR_INFORMATION)
            return
        self.pose_graph.add_node(location, self.correction(previous) @ odometry_pose)
        self.pose_graph.add_edge(
            Edge(previous, location, invert(self.odometry[previous]) @ odometry_pose, link_information(variance))
        )

    def close_loops(self, links: list[tuple[int, int, np.ndarray, Variance]]) -> list[ClosureOutcome]:
        """Add the links ``(old, new, T_old^-1 T_new, variance)`` of one update, each with its
        outcome. A link to another map joins it as it comes. The others are optimised together
        and kept only if no link of the graph then disagrees by more than RGBD/OptimizeMaxError
        of its standard deviation, else none of them: ``Rtabmap::process`` checks an update's
        links together ("Rejecting all added loop closures ... in this iteration")."""
        outcomes: dict[int, ClosureOutcome] = {}
        within: dict[int, Edge] = {}
        for i, (old, new, relative, variance) in enumerate(links):
            edge = Edge(old, new, relative, link_information(variance))
            if self.map_of(old) != self.map_of(new):
                self._join_maps(old, new, relative)
                self.pose_graph.add_edge(edge)
                outcomes[i] = ClosureOutcome(True, "maps joined", joined_maps=True)
            else:
                within[i] = edge
        if within:
            together = self._close_together(list(within.values()))
            outcomes.update(dict.fromkeys(within, together))
        return [outcomes[i] for i in range(len(links))]

    def _close_together(self, edges: list[Edge]) -> ClosureOutcome:
        """Add ``edges``, optimise once, and keep them all if consistent, else remove them all."""
        saved = dict(self.poses)
        for edge in edges:
            self.pose_graph.add_edge(edge)
        before, after = self.pose_graph.optimize(self.iterations)
        error = self.largest_link_error()
        if self.max_error > 0 and error > self.max_error:
            for edge in edges:
                self.pose_graph.remove_edge(edge)
            self.pose_graph.poses.update(saved)
            reason = f"optimisation error {error:.1f} > {self.max_error:g}"
            if len(edges) > 1:
                reason += f" (with the update's {len(edges)} links)"
            return ClosureOutcome(False, reason, before, after)
        return ClosureOutcome(True, "accepted", before, after)

    def largest_link_error(self) -> float:
        """Largest disagreement of a link with the graph, in units of its standard deviation."""
        worst = 0.0
        for edge in self.pose_graph.edges:
            translation, rotation = self.pose_graph.edge_residual(edge)
            sigma_rotation, sigma_translation = np.diag(edge.information)[[0, 3]] ** -0.5
            worst = max(worst, translation / sigma_translation, rotation / sigma_rotation)
        return worst

    def _join_maps(self, old: int, new: int, relative: np.ndarray) -> None:
        """Move the newer map rigidly so that the link holds, and drop its anchors."""
        keep, moved = sorted((self.map_of(old), self.map_of(new)))
        if self.map_of(new) == keep:
            relative, old, new = invert(relative), new, old
        shift = self.poses[old] @ relative @ invert(self.poses[new])
        for location, session in self.session.items():
            if self.map_of_session[session] == moved:
                self.poses[location] = shift @ self.poses[location]
                self.pose_graph.remove_prior(location)
        for session, joined in self.map_of_session.items():
            if joined == moved:
                self.map_of_session[session] = keep
