"""RGB-D SLAM (Endres et al., ICRA 2012 / T-RO 2014) as RGB-D SLAM v2 runs it, on OpenCV
features and a GTSAM pose graph.

Each frame is compared with candidate nodes (``candidates.py``): its predecessors, graph
neighbours of the newest node and keyframes sampled from the whole graph. RANSAC turns the
matches into rigid transformations (``motion.py``). A frame that matches at least one
candidate becomes a node with an edge per match (v2's ``GraphManager::nodeComparisons``);
a frame that matches none is dropped and the next frame is compared again, with newly
sampled keyframes, until one matches (how v2 relocalises). With ``keep_all_nodes`` it is
kept instead, tied to the newest node by a no-motion edge, and v2 does the same for a
frame within 0.1 s of the newest node that did not match it. The graph is optimised
after every ``optimizer_skip_step`` nodes; at the end, as v2's batch run, edges whose error
stays above each of v2's three pruning thresholds in turn are dropped and the graph
optimised again.

As v2's ``concurrent_node_construction``, the next frame's features are extracted on a
thread of their own while the current frame is compared and inserted; extraction depends
only on the frames before (the adjusted detector thresholds), so the result is the same.
The comparisons of one frame are independent, so they run on the process's two worker
threads (the compiled matcher and RANSAC release the GIL); each draws its RANSAC samples
from a generator seeded by (seed, frame, node), so the result does not depend on the
scheduling. The online optimisation runs on the calling thread: on a worker thread (v2's
``concurrent_optimization``) GTSAM's peak stays in that thread's malloc arena, which
raised the peak memory of an 800-frame run from 555 to 706 MB.
"""

from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ...backend.pose_graph import information_from_sigmas
from ...dataset.frame import Frame
from ...frontend.features import FeatureExtractor, Features
from ...frontend.workers import workers
from ...geometry.camera import Camera
from ...geometry.se3 import transform_points
from ..base import Pipeline
from ..edges import EdgeKind
from ..events import (
    Event,
    FeatureMatches,
    FrameTracked,
    GraphEdge,
    GraphOptimized,
    KeyframeAdded,
    MapUpdated,
    TrackingLost,
    TrackingRecovered,
    TrackingStatus,
    TrajectoryFinal,
)
from ..stopwatch import Stopwatch
from ..thumbnails import thumbnail
from .candidates import PREDECESSOR, edge_targets
from .emm import observability
from .graph import NodeGraph
from .motion import (
    MeasuredFeatures,
    Motion,
    estimate_motion,
    g2o_information,
    match,
    moved_enough,
    smooth_enough,
    too_fast_reason,
)
from .node import Node
from .params import RgbdSlamParams

# The first node fixes the map frame. A new segment's anchor (viewslam_new_segment_after_lost_frames)
# only holds its segment near the last known pose until an edge joins it to the map.
ORIGIN_INFORMATION = information_from_sigmas(1e-6, 1e-6)
ANCHOR_INFORMATION = information_from_sigmas(1.0, 1.0)
FINAL_OPTIMIZER_ITERATIONS = 100
# v2's no-motion edge: only for a frame this close in time to the newest node, unless
# keep_all_nodes; information I / dt (nodeComparisons).
NO_MOTION_MAX_GAP_S = 0.1
# v2's batch run (OpenNIListener::evaluation), after the final optimisation, prunes the edges
# whose squared Mahalanobis error exceeds each of these in turn, optimising again after each
# round that pruned any (pruneEdgesWithErrorAbove(5), (1), (0.25)).
PRUNE_CHI2_ROUNDS = (5.0, 1.0, 0.25)
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
    """The successful attempt with most inliers (the earlier one on ties)."""
    return max((a for a in attempts if a.motion is not None), key=_inlier_count, default=None)


def _inlier_count(attempt: Attempt) -> int:
    assert attempt.motion is not None  # best_attempt compares the successful attempts only
    return attempt.motion.inlier_count


def no_motion_information(gap_s: float) -> np.ndarray:
    """v2's no-motion edge information ``I / dt``."""
    return g2o_information(1.0 / max(gap_s, 1e-3))


class RgbdSlam(Pipeline):
    """Each frame matched with recent, neighbouring and sampled nodes by features and RANSAC
    under the Kinect noise model, as RGB-D SLAM v2; every match an edge of a pose graph
    optimised online; a lost camera dropped until a node matches again."""

    name = "rgbdslam"
    Params = RgbdSlamParams
    params: RgbdSlamParams

    def __init__(self, camera: Camera, params: RgbdSlamParams | None = None, seed: int = 0):
        super().__init__(camera, params, seed)
        p = self.params
        self.extractor = FeatureExtractor(
            p.feature_detector_type,
            p.max_keypoints,
            camera,
            p.detector_grid_resolution,
            min_depth=p.minimum_depth,
            max_depth=p.maximum_depth or np.inf,
            adjuster_iterations=p.adjuster_max_iterations,
        )
        self.rng = np.random.default_rng(seed)
        self.graph = NodeGraph(p.backend_solver)
        self.tracked: list[TrackedFrame] = []
        self.lost = False
        self.lost_chain: MeasuredFeatures | None = None
        self.lost_chain_length = 0
        self.nodes_since_optimisation = 0
        self.loop_closed_since_optimisation = False
        self.node_builder: ThreadPoolExecutor | None = None
        self.prefetched: dict[int, Future] = {}

    # ------------------------------------------------------------------ frames
    def prefetch(self, frame: Frame) -> None:
        """v2's concurrent_node_construction: the frame's features start now, after those of
        the frames shown before it (one thread, so the detector thresholds adapt in order)."""
        if self.params.concurrent_node_construction:
            if self.node_builder is None:
                self.node_builder = ThreadPoolExecutor(1, thread_name_prefix="rgbdslam-node")
            self.prefetched[frame.index] = self.node_builder.submit(self._extract, frame)

    def _extract(self, frame: Frame) -> tuple[Features, MeasuredFeatures, float]:
        """The frame's features, those with a 3D point, and the milliseconds they took."""
        watch = Stopwatch()
        with watch("features"):
            features = self.extractor.extract(frame.rgb, frame.depth, frame.grey)
            measured = MeasuredFeatures.from_features(features)
        return features, measured, watch.ms["features"]

    def process(self, frame: Frame) -> list[Event]:
        watch = Stopwatch()
        events: list[Event] = []
        p = self.params
        prefetched = self.prefetched.pop(frame.index, None)
        features, measured, extraction_ms = prefetched.result() if prefetched else self._extract(frame)
        watch.add("features", extraction_ms)
        if len(measured) < p.min_matches and not (p.keep_all_nodes and len(self.graph)):
            reason = f"only {len(measured)} keypoints with depth (< {p.min_matches})"
            return self._lose(frame, features, [], events, watch, reason)
        if not len(self.graph):
            self._start_segment(frame, measured, np.eye(4), np.eye(4), ORIGIN_INFORMATION, events)
            return self._report(frame, features, None, [], events, watch, TrackingStatus.INITIALISING)

        newest = self.graph.newest.node_id
        gap_s = frame.timestamp - self.graph.newest.timestamp
        attempts: list[Attempt] = []
        if p.min_translation_meter > 0 or p.min_rotation_degree > 0:
            # v2 first compares with the newest node; a frame that stayed near it, or moved
            # faster than v2's bounds allow, is no node.
            attempts = self._compare(frame, measured, [(newest, PREDECESSOR)], watch, bounded=False)
            first = attempts[0].motion
            if first is not None and not (
                moved_enough(first.transform, p) and smooth_enough(first.transform, gap_s, p)
            ):
                status = self._recover(frame, attempts[0], events)
                self._attach(frame, newest, first.transform, self.graph.odometry[newest])
                return self._report(frame, features, attempts[0], attempts, events, watch, status)
            attempts = [a for a in attempts if a.motion is not None]
        targets = edge_targets(
            self.graph.order,
            self.graph.adjacency,
            self.graph.keyframes,
            newest,
            include_predecessor=not attempts,
            sequential=p.predecessor_candidates - 1,
            neighbours=p.neighbor_candidates,
            sampled=p.min_sampled_candidates,
            geodesic_depth=p.geodesic_depth,
            rng=self.rng,
        )
        attempts += self._compare(frame, measured, targets, watch)
        if p.observability_threshold > 0:
            with watch("emm"):
                self._check_environment(frame, measured, attempts)
        best = best_attempt(attempts)
        predecessor_matched = any(a.node_id == newest and a.motion is not None for a in attempts)
        no_motion = (best is None and p.keep_all_nodes) or (not predecessor_matched and gap_s < NO_MOTION_MAX_GAP_S)
        if best is None and not no_motion:
            return self._unmatched(frame, features, measured, attempts, events, watch)
        self._add_node(frame, measured, attempts, no_motion, gap_s, events, watch)
        if best is None:
            if not self.lost:
                self.lost = True
                events.append(
                    TrackingLost(
                        frame.index,
                        frame.timestamp,
                        self._no_match_reason(attempts) + "; kept under the no-motion assumption",
                    )
                )
            return self._report(frame, features, None, attempts, events, watch, TrackingStatus.LOST)
        status = self._recover(frame, best, events)
        return self._report(frame, features, best, attempts, events, watch, status)

    def _compare(
        self,
        frame: Frame,
        measured: MeasuredFeatures,
        candidates: list[tuple[int, str]],
        watch: Stopwatch,
        bounded: bool = True,
    ) -> list[Attempt]:
        """Register the frame with each candidate node, in parallel; stage times are summed.

        ``bounded``: as v2's edge construction, a motion faster than max_translation_meter or
        max_rotation_degree per second between the frame's and the node's times is refused.
        With viewslam_min_inlier_ratio (ours, off by default) a loop closure, and a lost
        camera's match against the map, must also have that share of its matches as inliers.
        """

        def register(candidate: tuple[int, str]) -> tuple[int, Motion | None, str, Stopwatch]:
            node_id, kind = candidate
            ratio = self.params.viewslam_min_inlier_ratio if kind != PREDECESSOR or self.lost else 0.0
            own = Stopwatch()
            return *self._register(frame, measured, node_id, self.graph.nodes[node_id].measured, own, ratio), own

        attempts = []
        for (node_id, kind), (matches, motion, reason, own) in zip(candidates, workers().map(register, candidates)):
            for stage, ms in own.ms.items():
                watch.add(stage, ms)
            gap_s = frame.timestamp - self.graph.nodes[node_id].timestamp
            if bounded and motion is not None and not smooth_enough(motion.transform, gap_s, self.params):
                reason = too_fast_reason(motion.transform, gap_s, self.params)
                motion = None
            attempts.append(Attempt(node_id, kind, matches, motion, reason))
        return attempts

    def _register(
        self,
        frame: Frame,
        measured: MeasuredFeatures,
        reference_id: int,
        reference: MeasuredFeatures,
        watch: Stopwatch,
        min_inlier_ratio: float = 0.0,
    ) -> tuple[int, Motion | None, str]:
        """Match two keypoint sets and estimate their motion: (matches, motion or None, reason)."""
        rng = np.random.default_rng([self.seed, frame.index, reference_id + 1])  # seed words are >= 0
        with watch("matching"):
            matches = match(measured, reference, self.params, rng)
        with watch("ransac"):
            motion, reason = estimate_motion(measured, reference, matches, self.params, rng, min_inlier_ratio)
        return len(matches[0]), motion, reason

    def _attach(self, frame: Frame, node_id: int, relative: np.ndarray, node_odometry: np.ndarray) -> None:
        self.tracked.append(TrackedFrame(frame.index, frame.timestamp, node_id, relative, node_odometry @ relative))

    def _recover(self, frame: Frame, best: Attempt, events: list[Event]) -> TrackingStatus:
        self.lost_chain, self.lost_chain_length = None, 0
        if not self.lost:
            return TrackingStatus.OK
        self.lost = False
        assert best.motion is not None  # recovered by a successful attempt
        events.append(
            TrackingRecovered(
                frame.index,
                frame.timestamp,
                f"relocalised against node {best.node_id} ({best.motion.inlier_count} inliers)",
            )
        )
        return TrackingStatus.RELOCALISED

    def _report(
        self,
        frame: Frame,
        features: Features,
        best: Attempt | None,
        attempts: list[Attempt],
        events: list[Event],
        watch: Stopwatch,
        status: TrackingStatus,
    ) -> list[Event]:
        """Close a tracked frame's events: the matches behind its pose and its FrameTracked."""
        tracked = self.tracked[-1]
        inliers = 0
        if best is not None:
            motion = best.motion
            assert motion is not None  # a frame's pose comes from a successful attempt
            reference = self.graph.nodes[best.node_id]
            current_keypoints = features.keypoints[features.has_depth][motion.frame_index]
            events.append(
                FeatureMatches(
                    frame.index,
                    f"node {best.node_id}",
                    current_keypoints,
                    reference.measured.features.keypoints[motion.node_index],
                    motion.inliers.copy(),
                )
            )
            inliers = motion.inlier_count
        pose = self.graph.poses.poses[tracked.node_id] @ tracked.relative
        events.append(
            FrameTracked(
                frame.index,
                frame.timestamp,
                pose,
                status,
                features=len(features),
                matches=max((a.matches for a in attempts), default=0),
                inliers=inliers,
                keyframe_id=tracked.node_id,
                timings_ms=watch.ms,
            )
        )
        return events

    # ------------------------------------------------------------------ no match
    @staticmethod
    def _no_match_reason(attempts: list[Attempt]) -> str:
        closest = max(attempts, key=lambda a: a.matches, default=None)
        return "no candidate node matched" + (f" (node {closest.node_id}: {closest.reason})" if closest else "")

    def _lose(
        self,
        frame: Frame,
        features: Features,
        attempts: list[Attempt],
        events: list[Event],
        watch: Stopwatch,
        reason: str,
    ) -> list[Event]:
        if len(self.graph) and not self.lost:
            self.lost = True
            events.append(TrackingLost(frame.index, frame.timestamp, reason))
        status = TrackingStatus.LOST if len(self.graph) else TrackingStatus.INITIALISING
        events.append(
            FrameTracked(
                frame.index,
                frame.timestamp,
                None,
                status,
                features=len(features),
                matches=max((a.matches for a in attempts), default=0),
                timings_ms=watch.ms,
            )
        )
        return events

    def _unmatched(
        self,
        frame: Frame,
        features: Features,
        measured: MeasuredFeatures,
        attempts: list[Attempt],
        events: list[Event],
        watch: Stopwatch,
    ) -> list[Event]:
        """No node matched: v2 drops the frame. With viewslam_new_segment_after_lost_frames
        (ours), lost frames that match each other start a new segment at the last pose."""
        after = self.params.viewslam_new_segment_after_lost_frames
        chained = (
            after > 0
            and self.lost_chain is not None
            and self._register(frame, measured, LOST_CHAIN, self.lost_chain, watch)[1] is not None
        )
        self.lost_chain = measured if after > 0 else None
        self.lost_chain_length = self.lost_chain_length + 1 if chained else 1
        if after == 0 or self.lost_chain_length < after or not self.tracked:
            return self._lose(frame, features, attempts, events, watch, self._no_match_reason(attempts))
        last = self.tracked[-1]
        anchor = self._start_segment(
            frame,
            measured,
            self.graph.poses.poses[last.node_id] @ last.relative,
            last.odometry,
            ANCHOR_INFORMATION,
            events,
        )
        self.lost = False
        self.lost_chain, self.lost_chain_length = None, 0
        events.append(
            TrackingRecovered(
                frame.index,
                frame.timestamp,
                f"{after} frames track each other but not the map: "
                f"new graph segment from node {anchor} at the last known pose",
            )
        )
        return self._report(frame, features, None, attempts, events, watch, TrackingStatus.INITIALISING)

    # ------------------------------------------------------------------ graph
    def _new_node(self, frame: Frame, measured: MeasuredFeatures, measured_pose: bool = True) -> Node:
        """A node for ``frame``, in a segment of its own until edges place it."""
        node_id = len(self.graph)
        return Node.from_frame(
            node_id, frame.index, frame.timestamp, measured, frame.rgb, frame.depth, node_id, measured_pose
        )

    def _insert(self, node: Node, pose: np.ndarray, odometry: np.ndarray, frame: Frame, events: list[Event]) -> None:
        """Put ``node`` in the graph at ``pose``; the frame becomes its first tracked frame."""
        self.graph.add(node, pose, odometry)
        self._attach(frame, node.node_id, np.eye(4), odometry)
        events.append(
            KeyframeAdded(
                node.node_id, frame.index, frame.timestamp, pose.copy(), thumbnail(frame.rgb), frame.depth.copy()
            )
        )
        if node.measured_pose:
            points, colors = node.cloud(self.camera)
            events.append(MapUpdated(frame.index, transform_points(pose, points), colors))

    def _start_segment(
        self,
        frame: Frame,
        measured: MeasuredFeatures,
        pose: np.ndarray,
        odometry: np.ndarray,
        information: np.ndarray,
        events: list[Event],
    ) -> int:
        node = self._new_node(frame, measured)
        self.graph.segments.add(node.node_id)
        self._insert(node, pose, odometry, frame, events)
        self.graph.keyframes.append(node.node_id)
        self.graph.poses.add_prior(node.node_id, pose, information)
        return node.node_id

    def _add_node(
        self,
        frame: Frame,
        measured: MeasuredFeatures,
        attempts: list[Attempt],
        no_motion: bool,
        gap_s: float,
        events: list[Event],
        watch: Stopwatch,
    ) -> None:
        """Make the frame a node with an edge per successful attempt, and with v2's no-motion
        edge to the newest node when asked; then keyframes and optimisation as v2."""
        graph = self.graph
        best = best_attempt(attempts)
        newest = graph.newest
        node = self._new_node(frame, measured, measured_pose=best is not None)
        if best is None:
            node.segment = graph.segment[newest.node_id]
            pose, odometry = graph.poses.poses[newest.node_id], graph.odometry[newest.node_id]
        else:
            node.segment = graph.segment[best.node_id]
            sequential = best_attempt([a for a in attempts if a.kind == PREDECESSOR]) or best
            assert sequential.motion is not None and best.motion is not None  # best_attempt's choices succeeded
            odometry = graph.odometry[sequential.node_id] @ sequential.motion.transform
            # v2's no-motion edge also sets the new vertex's estimate to the newest node's pose.
            pose = (
                graph.poses.poses[newest.node_id]
                if no_motion
                else graph.poses.poses[best.node_id] @ best.motion.transform
            )
        self._insert(node, pose, odometry, frame, events)

        loop_closed = self.loop_closed_since_optimisation
        for attempt in attempts:
            if attempt.motion is not None:
                loop_closed |= graph.connect(
                    attempt.node_id, node.node_id, attempt.motion.transform, attempt.motion.information
                )
                loop_closed |= attempt.kind != PREDECESSOR
            event = self._edge_event(frame, node.node_id, attempt)
            if event.accepted or event.kind == EdgeKind.LOOP:
                events.append(event)
        if no_motion:
            graph.connect(newest.node_id, node.node_id, np.eye(4), no_motion_information(gap_s))
        # v2: a node matching no keyframe makes its predecessor one, so keyframes stay connected.
        unanchored = not any(a.motion is not None and a.node_id in graph.keyframes for a in attempts)
        if unanchored and node.node_id - 1 not in graph.keyframes:
            graph.keyframes.append(node.node_id - 1)

        self.nodes_since_optimisation += 1
        self.loop_closed_since_optimisation = loop_closed
        if self.nodes_since_optimisation >= self._optimisation_interval():
            self.nodes_since_optimisation = 0
            self.loop_closed_since_optimisation = False
            with watch("optimisation"):
                events.append(self._optimise(frame.index, self.params.optimizer_iterations))
            if loop_closed:
                with watch("map"):
                    events.append(graph.map(frame.index, self.camera))

    def _optimisation_interval(self) -> int:
        """Nodes between online optimisations: optimizer_skip_step, or with
        viewslam_optimization_spacing (ours) more on a large graph."""
        return max(self.params.optimizer_skip_step, int(len(self.graph) * self.params.viewslam_optimization_spacing))

    def _check_environment(self, frame: Frame, measured: MeasuredFeatures, attempts: list[Attempt]) -> None:
        """Reject the successful attempts whose transformation the depth images contradict."""
        threshold = self.params.observability_threshold
        candidate = self._new_node(frame, measured)
        for attempt in attempts:
            if attempt.motion is None:
                continue
            share = observability(
                self.graph.nodes[attempt.node_id],
                candidate,
                attempt.motion.transform,
                self.camera,
                self.params.emm_depth_tolerance,
            )
            if share < threshold:
                attempt.motion = None
                attempt.reason = f"environment measurement model: {share:.2f} of the depth agrees (< {threshold})"

    def _edge_event(self, frame: Frame, node_id: int, attempt: Attempt) -> GraphEdge:
        motion = attempt.motion
        kind = self.graph.kinds.kind(attempt.node_id, node_id)
        if motion is None:
            return GraphEdge(frame.index, attempt.node_id, node_id, False, attempt.reason, kind, detection=attempt.kind)
        return GraphEdge(
            frame.index,
            attempt.node_id,
            node_id,
            True,
            f"{motion.inlier_count} inliers of {attempt.matches} matches",
            kind,
            score=float(motion.inlier_count),
            inliers=motion.inlier_count,
            detection=attempt.kind,
        )

    def _optimise(self, frame_index: int, iterations: float) -> GraphOptimized:
        """v2's optimizer_iterations: that many iterations when >= 1, else until the error
        improves by less than that fraction."""
        if iterations >= 1:
            before, after = self.graph.poses.optimize(int(iterations))
        else:
            before, after = self.graph.poses.optimize(FINAL_OPTIMIZER_ITERATIONS, relative_tolerance=iterations)
        ids = np.array(self.graph.order, dtype=int)
        return GraphOptimized(frame_index, ids, np.stack([self.graph.poses.poses[i] for i in ids]), before, after)

    # ------------------------------------------------------------------ end of run
    def finish(self) -> list[Event]:
        if self.node_builder is not None:
            self.node_builder.shutdown(cancel_futures=True)
            self.node_builder, self.prefetched = None, {}
        events: list[Event] = []
        last_frame = self.tracked[-1].frame_index if self.tracked else -1
        if len(self.graph):
            events.append(self._optimise(last_frame, FINAL_OPTIMIZER_ITERATIONS))
            for threshold in PRUNE_CHI2_ROUNDS:
                if self.graph.prune_edges_with_error_above(threshold):
                    events.append(self._optimise(last_frame, FINAL_OPTIMIZER_ITERATIONS))
            events.append(self.graph.map(last_frame, self.camera))
        if self.tracked:
            poses = np.stack([self.graph.poses.poses[t.node_id] @ t.relative for t in self.tracked])
            odometry = np.stack([t.odometry for t in self.tracked])
        else:
            poses = odometry = np.zeros((0, 4, 4))
        events.append(
            TrajectoryFinal(
                np.array([t.frame_index for t in self.tracked], dtype=int),
                np.array([t.timestamp for t in self.tracked], dtype=np.float64),
                poses,
                odometry,
            )
        )
        return events
