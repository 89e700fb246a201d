"""RGB-D SLAM (Endres et al., ICRA 2012 / T-RO 2014) on OpenCV features and a GTSAM pose graph.

Each frame is matched with the most recent nodes; RANSAC turns the matches into rigid
transformations. A frame that moved far enough from its node becomes a new node: it is
also compared with graph neighbours and randomly sampled nodes (loop closures), gets an
edge per successful comparison, and the graph is optimised. Other frames keep their pose
relative to their node, so loop closures move them along with it.

The comparisons of one frame are independent, so they run on two threads (OpenCV's
matcher and most of numpy release the GIL); each draws its RANSAC samples from a
generator seeded by (seed, frame, node), so the result does not depend on the scheduling.
"""

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ...backend.pose_graph import Edge, PoseGraph, information_from_sigmas
from ...dataset.frame import Frame
from ...frontend.features import FeatureExtractor, Features
from ...geometry.camera import Camera
from ...geometry.se3 import rotation_angle, transform_points
from ..base import Pipeline
from ..edges import EdgeClassifier, EdgeKind
from ..stopwatch import Stopwatch
from ..thumbnails import thumbnail
from ..events import (Event, FeatureMatches, FrameTracked, GraphOptimized, GraphEdge, KeyframeAdded, MapUpdated,
                      TrackingLost, TrackingRecovered, TrackingStatus, TrajectoryFinal)
from .candidates import PREDECESSOR, loop_candidates, predecessors
from .emm import observability
from .motion import MeasuredFeatures, Motion, estimate_motion, match
from .node import Node
from .params import RgbdSlamParams
from .segments import Segments

# The first node fixes the map frame. A new segment's anchor only holds its segment near the
# last known pose until an edge joins it to the map, when the anchor prior is dropped.
ORIGIN_INFORMATION = information_from_sigmas(1e-6, 1e-6)
ANCHOR_INFORMATION = information_from_sigmas(1.0, 1.0)
FINAL_OPTIMIZER_ITERATIONS = 100
MAX_MAP_POINTS = 200_000
# On a graph of N nodes the online optimisation runs at most every N * this many nodes.
ONLINE_OPTIMISATION_SPACING = 0.05
COMPARISON_THREADS = 2
# Stands for the lost chain's frame in the seed of a comparison (node ids are >= 0).
LOST_CHAIN = -1


@dataclass
class Attempt:
    """One candidate node compared with the current frame: the motion found, or why not."""

    node_id: int
    kind: str
    matches: int
    motion: Motion | None
    reason: str


@dataclass
class TrackedFrame:
    """A frame with a pose: ``relative`` to its node, and the pose odometry alone gave it."""

    frame_index: int
    timestamp: float
    node_id: int
    relative: np.ndarray
    odometry: np.ndarray


def best_attempt(attempts: list[Attempt]) -> Attempt | None:
    """The successful attempt with most inliers (the earlier, i.e. more recent node, on ties)."""
    return max((a for a in attempts if a.motion is not None), key=lambda a: a.motion.inlier_count, default=None)


class RgbdSlam(Pipeline):
    name = "rgbdslam"
    Params = RgbdSlamParams

    def __init__(self, camera: Camera, params: RgbdSlamParams | None = None, seed: int = 0):
        super().__init__(camera, params, seed)
        p = self.params
        self.extractor = FeatureExtractor(p.feature_detector_type, p.max_keypoints, camera, p.detector_grid_resolution,
                                          min_depth=p.minimum_depth, max_depth=p.maximum_depth,
                                          adjuster_iterations=p.adjuster_max_iterations)
        self.rng = np.random.default_rng(seed)
        self.graph = PoseGraph()
        self.nodes: dict[int, Node] = {}
        self.node_order: list[int] = []
        self.adjacency: dict[int, set[int]] = {}
        self.node_segment: dict[int, int] = {}
        self.node_odometry: dict[int, np.ndarray] = {}
        self.segments = Segments()
        self.edges = EdgeClassifier()
        self.tracked: list[TrackedFrame] = []
        self.lost = False
        self.lost_chain: MeasuredFeatures | None = None
        self.lost_chain_length = 0
        self.nodes_since_optimisation = 0
        self.loop_closed_since_optimisation = False
        self.comparisons = ThreadPoolExecutor(COMPARISON_THREADS, thread_name_prefix="rgbdslam-comparison")

    # ------------------------------------------------------------------ frames
    def process(self, frame: Frame) -> list[Event]:
        watch = Stopwatch()
        events: list[Event] = []
        with watch("features"):
            features = self.extractor.extract(frame.rgb, frame.depth)
            measured = MeasuredFeatures.from_features(features, self.params, self.camera)
        if len(measured) < self.params.min_matches:
            reason = f"only {len(measured)} keypoints with depth (< {self.params.min_matches})"
            return self._lose(frame, features, [], events, watch, reason)
        if not self.nodes:
            self._start_segment(frame, measured, np.eye(4), np.eye(4), ORIGIN_INFORMATION, events)
            return self._report(frame, features, None, [], events, watch, TrackingStatus.INITIALISING)

        # Only nodes get edges, so a frame that stays near the newest node needs no other
        # comparison; the other predecessors are compared when it may become a node.
        newest, *older = predecessors(self.node_order, self.params.predecessor_candidates)
        attempts = self._compare(frame, measured, [(newest, PREDECESSOR)], watch)
        if attempts[0].motion is None or self._moved_enough(attempts[0].motion.transform):
            attempts += self._compare(frame, measured, [(n, PREDECESSOR) for n in older], watch)
        best = best_attempt(attempts)
        if best is not None and not self._moved_enough(best.motion.transform):
            status = self._recover(frame, best, events)
            self._attach(frame, best.node_id, best.motion.transform, self.node_odometry[best.node_id])
            return self._report(frame, features, best, attempts, events, watch, status)

        others = loop_candidates(self.node_order, self.adjacency, self.node_order[-1], {a.node_id for a in attempts},
                                 self.params.neighbor_candidates, self.params.min_sampled_candidates,
                                 self.params.geodesic_depth, self.rng)
        attempts += self._compare(frame, measured, others, watch)
        new_node = self._add_node(frame, measured, attempts, events, watch)
        if new_node is None:
            return self._lost_or_new_segment(frame, features, measured, attempts, events, watch)
        best = best_attempt(attempts)
        status = self._recover(frame, best, events)
        return self._report(frame, features, best, attempts, events, watch, status)

    def _compare(self, frame: Frame, measured: MeasuredFeatures, candidates: list[tuple[int, str]],
                 watch: Stopwatch) -> list[Attempt]:
        """Register the frame with each candidate node, in parallel; stage times are summed.

        A loop closure, and a lost camera's match against the map, must also have
        min_inlier_ratio of its matches as inliers: repeated texture (one font on every
        poster) lets a wrong transformation gather min_matches inliers among many matches,
        and nothing else checks these edges. Tracking against predecessors (and the lost
        frames' chain) keeps only min_matches, so that faint texture, where most matches
        are wrong, can still be followed.
        """
        def register(candidate: tuple[int, str]) -> tuple[int, Motion | None, str, Stopwatch]:
            node_id, kind = candidate
            ratio = self.params.min_inlier_ratio if kind != PREDECESSOR or self.lost else 0.0
            own = Stopwatch()
            return *self._register(frame, measured, node_id, self.nodes[node_id].measured, own, ratio), own

        attempts = []
        for (node_id, kind), (matches, motion, reason, own) in zip(candidates, self.comparisons.map(register, candidates)):
            for stage, ms in own.ms.items():
                watch.add(stage, ms)
            attempts.append(Attempt(node_id, kind, matches, motion, reason))
        return attempts

    def _register(self, frame: Frame, measured: MeasuredFeatures, reference_id: int, reference: MeasuredFeatures,
                  watch: Stopwatch, min_inlier_ratio: float = 0.0) -> tuple[int, Motion | None, str]:
        """Match two keypoint sets and estimate their motion: (matches, motion or None, reason)."""
        with watch("matching"):
            matches = match(measured, reference, self.params.nn_distance_ratio)
        with watch("ransac"):
            rng = np.random.default_rng([self.seed, frame.index, reference_id + 1])  # seed words are >= 0
            motion, reason = estimate_motion(measured, reference, matches, self.params, rng, min_inlier_ratio)
        return len(matches[0]), motion, reason

    def _moved_enough(self, node_from_frame: np.ndarray) -> bool:
        return bool(np.linalg.norm(node_from_frame[:3, 3]) >= self.params.min_translation_meter
                    or np.degrees(rotation_angle(node_from_frame[:3, :3])) >= self.params.min_rotation_degree)

    def _attach(self, frame: Frame, node_id: int, relative: np.ndarray, node_odometry: np.ndarray) -> None:
        self.tracked.append(TrackedFrame(frame.index, frame.timestamp, node_id, relative, node_odometry @ relative))

    def _recover(self, frame: Frame, best: Attempt, events: list[Event]) -> TrackingStatus:
        self.lost_chain, self.lost_chain_length = None, 0
        if not self.lost:
            return TrackingStatus.OK
        self.lost = False
        events.append(TrackingRecovered(frame.index, frame.timestamp,
                                        f"relocalised against node {best.node_id} ({best.motion.inlier_count} inliers)"))
        return TrackingStatus.RELOCALISED

    def _report(self, frame: Frame, features: Features, best: Attempt | None, attempts: list[Attempt],
                events: list[Event], watch: Stopwatch, status: TrackingStatus) -> list[Event]:
        """Close a tracked frame's events: the matches behind its pose and its FrameTracked."""
        tracked = self.tracked[-1]
        inliers = 0
        if best is not None:
            motion = best.motion
            reference = self.nodes[best.node_id]
            current_keypoints = features.keypoints[features.has_depth][motion.frame_index]
            events.append(FeatureMatches(frame.index, f"node {best.node_id}", reference.frame_index, current_keypoints,
                                         reference.measured.features.keypoints[motion.node_index],
                                         motion.inliers.copy()))
            inliers = motion.inlier_count
        events.append(FrameTracked(frame.index, frame.timestamp, self.graph.poses[tracked.node_id] @ tracked.relative,
                                   status, features=len(features), matches=max((a.matches for a in attempts), default=0),
                                   inliers=inliers, keyframe_id=tracked.node_id, timings_ms=watch.ms))
        return events

    # ------------------------------------------------------------------ loss and kidnap
    def _lose(self, frame: Frame, features: Features, attempts: list[Attempt], events: list[Event],
              watch: Stopwatch, reason: str) -> list[Event]:
        if self.nodes and not self.lost:
            self.lost = True
            events.append(TrackingLost(frame.index, frame.timestamp, reason))
        status = TrackingStatus.LOST if self.nodes else TrackingStatus.INITIALISING
        events.append(FrameTracked(frame.index, frame.timestamp, None, status, features=len(features),
                                   matches=max((a.matches for a in attempts), default=0), timings_ms=watch.ms))
        return events

    def _lost_or_new_segment(self, frame: Frame, features: Features, measured: MeasuredFeatures,
                             attempts: list[Attempt], events: list[Event], watch: Stopwatch) -> list[Event]:
        """No node matched. If the last few lost frames match each other, the camera is
        tracking a place the map does not hold: start a new segment there."""
        chained = (self.lost_chain is not None
                   and self._register(frame, measured, LOST_CHAIN, self.lost_chain, watch)[1] is not None)
        self.lost_chain = measured
        self.lost_chain_length = self.lost_chain_length + 1 if chained else 1
        if self.lost_chain_length < self.params.segment_after_lost_frames or not self.tracked:
            closest = max(attempts, key=lambda a: a.matches, default=None)
            reason = "no candidate node matched" + (f" (node {closest.node_id}: {closest.reason})" if closest else "")
            return self._lose(frame, features, attempts, events, watch, reason)
        last = self.tracked[-1]
        anchor = self._start_segment(frame, measured, self.graph.poses[last.node_id] @ last.relative, last.odometry,
                                     ANCHOR_INFORMATION, events)
        self.lost = False
        self.lost_chain, self.lost_chain_length = None, 0
        events.append(TrackingRecovered(frame.index, frame.timestamp,
                                        f"{self.params.segment_after_lost_frames} frames track each other but not the map: "
                                        f"new graph segment from node {anchor} at the last known pose"))
        return self._report(frame, features, None, attempts, events, watch, TrackingStatus.INITIALISING)

    # ------------------------------------------------------------------ graph
    def _new_node(self, frame: Frame, measured: MeasuredFeatures) -> Node:
        """A node for ``frame``, in a segment of its own until edges place it."""
        node_id = len(self.node_order)
        return Node.from_frame(node_id, frame.index, frame.timestamp, measured, frame.rgb, frame.depth, node_id)

    def _insert(self, node: Node, pose: np.ndarray, odometry: np.ndarray, frame: Frame,
                events: list[Event]) -> None:
        """Put ``node`` in the graph at ``pose``; the frame becomes its first tracked frame."""
        self.nodes[node.node_id] = node
        self.node_order.append(node.node_id)
        self.adjacency[node.node_id] = set()
        self.node_segment[node.node_id] = node.segment
        self.node_odometry[node.node_id] = odometry
        self.edges.add_node(node.node_id, frame.timestamp)
        self.graph.add_node(node.node_id, pose)
        self._attach(frame, node.node_id, np.eye(4), odometry)
        events.append(KeyframeAdded(node.node_id, frame.index, frame.timestamp, pose.copy(),
                                    node.measured.features.keypoints.copy(), thumbnail(frame.rgb), frame.depth.copy()))
        points, colors = node.cloud(self.camera)
        events.append(MapUpdated(frame.index, transform_points(pose, points), colors))

    def _start_segment(self, frame: Frame, measured: MeasuredFeatures, pose: np.ndarray, odometry: np.ndarray,
                       information: np.ndarray, events: list[Event]) -> int:
        node = self._new_node(frame, measured)
        self.segments.add(node.node_id)
        self._insert(node, pose, odometry, frame, events)
        self.graph.add_prior(node.node_id, pose, information)
        return node.node_id

    def _add_node(self, frame: Frame, measured: MeasuredFeatures, attempts: list[Attempt], events: list[Event],
                  watch: Stopwatch) -> int | None:
        """Make the frame a node with an edge per successful attempt; None if none succeeded."""
        if best_attempt(attempts) is None:
            return None
        node = self._new_node(frame, measured)
        if self.params.observability_threshold > 0:
            with watch("emm"):
                self._check_environment(node, attempts)
        best = best_attempt(attempts)
        if best is None:
            return None
        node.segment = self.node_segment[best.node_id]
        sequential = best_attempt([a for a in attempts if a.kind == PREDECESSOR]) or best
        odometry = self.node_odometry[sequential.node_id] @ sequential.motion.transform
        self._insert(node, self.graph.poses[best.node_id] @ best.motion.transform, odometry, frame, events)

        loop_closed = self.loop_closed_since_optimisation
        for attempt in attempts:
            if attempt.motion is not None:
                self.graph.add_edge(Edge(attempt.node_id, node.node_id, attempt.motion.transform,
                                         attempt.motion.information, robust=attempt.kind != PREDECESSOR))
                self.adjacency[attempt.node_id].add(node.node_id)
                self.adjacency[node.node_id].add(attempt.node_id)
                loop_closed |= self.segments.join(self.graph, self.node_segment, attempt.node_id, node.node_id,
                                                  attempt.motion.transform)
            if attempt.kind != PREDECESSOR:
                loop_closed |= attempt.motion is not None
            event = self._edge_event(frame, node.node_id, attempt)
            if event.accepted or event.kind == EdgeKind.LOOP:
                events.append(event)

        self.nodes_since_optimisation += 1
        self.loop_closed_since_optimisation = loop_closed
        if self.nodes_since_optimisation >= self._optimisation_interval():
            with watch("optimisation"):
                events.append(self._optimise(frame.index, self.params.optimizer_iterations))
            if loop_closed:
                with watch("map"):
                    events.append(self._rebuilt_map(frame.index))
        return node.node_id

    def _optimisation_interval(self) -> int:
        """Nodes between online optimisations: optimizer_skip_step, or more on a large graph
        so that the batch optimisations' total cost stays bounded on long runs."""
        return max(self.params.optimizer_skip_step, int(len(self.nodes) * ONLINE_OPTIMISATION_SPACING))

    def _check_environment(self, node: Node, attempts: list[Attempt]) -> None:
        """Reject the successful attempts whose transformation the depth images contradict."""
        threshold = self.params.observability_threshold
        for attempt in attempts:
            if attempt.motion is None:
                continue
            share = observability(self.nodes[attempt.node_id], node, attempt.motion.transform, self.camera,
                                  self.params.emm_depth_tolerance)
            if share < threshold:
                attempt.motion = None
                attempt.reason = f"environment measurement model: {share:.2f} of the depth agrees (< {threshold})"

    def _edge_event(self, frame: Frame, node_id: int, attempt: Attempt) -> GraphEdge:
        motion = attempt.motion
        kind = self.edges.kind(attempt.node_id, node_id)
        if motion is None:
            return GraphEdge(frame.index, attempt.node_id, node_id, False, attempt.reason, kind,
                             detection=attempt.kind)
        return GraphEdge(frame.index, attempt.node_id, node_id, True,
                         f"{motion.inlier_count} inliers of {attempt.matches} matches", kind, motion.transform.copy(),
                         score=float(motion.inlier_count), inliers=motion.inlier_count, detection=attempt.kind)

    def _optimise(self, frame_index: int, iterations: int) -> GraphOptimized:
        before, after = self.graph.optimize(iterations)
        self.nodes_since_optimisation = 0
        self.loop_closed_since_optimisation = False
        ids = np.array(self.node_order, dtype=int)
        return GraphOptimized(frame_index, ids, np.stack([self.graph.poses[i] for i in ids]), before, after)

    def _rebuilt_map(self, frame_index: int) -> MapUpdated:
        """The whole map from every node's current pose, thinned to at most MAX_MAP_POINTS."""
        samples = sum(int(np.count_nonzero(node.depth)) for node in self.nodes.values())
        step = max(1, int(np.ceil(np.sqrt(samples / MAX_MAP_POINTS))))
        points, colors = [], []
        for node_id, node in self.nodes.items():
            node_points, node_colors = node.cloud(self.camera, step)
            points.append(transform_points(self.graph.poses[node_id], node_points))
            colors.append(node_colors)
        return MapUpdated(frame_index, np.concatenate(points), np.concatenate(colors), replace=True)

    # ------------------------------------------------------------------ end of run
    def finish(self) -> list[Event]:
        self.comparisons.shutdown()
        events: list[Event] = []
        last_frame = self.tracked[-1].frame_index if self.tracked else -1
        if self.nodes:
            events.append(self._optimise(last_frame, FINAL_OPTIMIZER_ITERATIONS))
            events.append(self._rebuilt_map(last_frame))
        if self.tracked:
            poses = np.stack([self.graph.poses[t.node_id] @ t.relative for t in self.tracked])
            odometry = np.stack([t.odometry for t in self.tracked])
        else:
            poses = odometry = np.zeros((0, 4, 4))
        events.append(TrajectoryFinal(np.array([t.frame_index for t in self.tracked], dtype=int),
                                      np.array([t.timestamp for t in self.tracked], dtype=np.float64),
                                      poses, odometry))
        return events
