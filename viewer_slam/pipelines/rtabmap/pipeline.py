"""The RTAB-Map pipeline: frame-to-map odometry feeding a graph of locations with
appearance-based loop closure detection under memory management."""

import time
from dataclasses import dataclass

import numpy as np

from ...dataset.frame import Frame
from ...frontend.features import FeatureExtractor, Features
from ...geometry.camera import Camera
from ...geometry.se3 import invert, rotation_angle, transform_points
from ..base import Pipeline
from ..edges import EdgeClassifier
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
from ..maps import rebuilt_map
from ..stopwatch import Stopwatch
from ..thumbnails import thumbnail
from .bayes import Hypothesis
from .correspondences import TreeSeeds
from .graph import LocationGraph, Variance
from .loop_closure import (
    AppearanceDetector,
    Registration,
    nearby_locations,
    proximity_candidates,
    register,
    within_filtering_radius,
)
from .memory import Link, Location, Memory, similarity
from .odometry import FrameToMapOdometry, OdometryResult
from .params import RtabmapParams
from .vocabulary import Vocabulary

DETECTION = {Link.LOOP: "appearance", Link.PROXIMITY: "proximity"}
STAGES = ("features", "odometry", "vocabulary", "bayes", "verification", "optimisation", "memory")
CLOUD_POINTS_ACROSS = 64  # coarse cloud per location: this many depth samples per image row
MAP_POINTS_LIMIT = 200_000  # a rebuilt map is subsampled to at most this many points
# Vis/MinDepth 0 means no limit, but a zero depth is a missing one (a TUM depth image's 0),
# so the nearest usable depth is just above it.
NEAREST_MEASURED_DEPTH = 1e-3


@dataclass
class Registered:
    """A verified registration of the update, to be linked with the update's others."""

    old: Location
    kind: Link
    score: float
    registration: Registration

    @property
    def inliers(self) -> int:
        return self.registration.inliers

    @property
    def relation(self) -> tuple[np.ndarray, Variance]:
        """``T_old^-1 T_new`` and its variance, as the graph takes a link."""
        assert self.registration.relative is not None  # only a registration with a pose is kept
        return self.registration.relative, self.registration.variance


@dataclass
class _FrameRecord:
    """A frame with odometry and the location its final pose hangs from."""

    index: int
    timestamp: float
    odometry_pose: np.ndarray
    location: int


class Rtabmap(Pipeline):
    """Frame-to-map odometry; a location every Rtabmap/DetectionRate seconds once the camera
    moved RGBD/LinearUpdate or RGBD/AngularUpdate; loop closures by appearance and by
    proximity, verified by PnP and kept if the optimised graph agrees with them."""

    name = "rtabmap"
    Params = RtabmapParams
    params: RtabmapParams

    def __init__(self, camera: Camera, params: RtabmapParams | None = None, seed: int = 0):
        super().__init__(camera, params, seed)
        p = self.params
        self.extractor = FeatureExtractor(
            p.feature_kind,
            p.odometry_max_features,
            camera,
            min_depth=max(p.min_depth, NEAREST_MEASURED_DEPTH),
            max_depth=p.max_depth or np.inf,
            depth_mask=p.depth_as_mask,
            depth_smoothing=True,
        )
        self.tree_seeds = TreeSeeds(seed)  # the odometry's and the loop closures' k-d trees
        self.odometry = FrameToMapOdometry(camera, p, self.tree_seeds)
        self.vocabulary = Vocabulary(p.word_nndr, seed)
        self.memory = Memory(self.vocabulary, p.stm_size, p.recent_wm_ratio)
        self.edges = EdgeClassifier()
        self.graph = LocationGraph(p.optimizer_iterations, p.optimize_max_error)
        self.detector = AppearanceDetector()
        self.session = -1
        self.current_location: int | None = None
        self.last_tick = -np.inf
        self.last_hypothesis = 0.0  # the previous update's hypothesis value (Rtabmap/LoopRatio)
        self.posterior_max = 0.0
        self.lost = False
        self.new_map_due = False  # viewslam/NewMapOnLoss: odometry was lost since the last location
        self.odometry_variance = Variance()  # of the link to the next location (viewslam/LinkCovariance)
        self.records: list[_FrameRecord] = []
        self.cloud_step = max(1, camera.width // CLOUD_POINTS_ACROSS)

    # -- per frame ---------------------------------------------------------------------

    def process(self, frame: Frame) -> list[Event]:
        watch = Stopwatch(STAGES)
        features = watch("features", self.extractor.extract, frame.rgb, frame.depth)
        odometry = watch("odometry", self.odometry.process, features, frame.timestamp)
        if odometry.kept is not None:
            features = features.subset(odometry.kept)
        events: list[Event] = []
        if odometry.matched_pixels is not None and len(odometry.matched_pixels):
            events.append(
                FeatureMatches(
                    frame.index, "local map", odometry.matched_pixels, odometry.projected_pixels, odometry.inlier_mask
                )
            )
        pose = None
        due = self._detection_due(frame.timestamp)
        if odometry.pose is None:
            status = TrackingStatus.LOST if self.odometry.initialised or self.lost else TrackingStatus.INITIALISING
            self.new_map_due |= self.params.new_map_on_loss and self.odometry.initialised
            if not self.lost and self.odometry.initialised:
                self.lost = True
                events.append(
                    TrackingLost(
                        frame.index,
                        frame.timestamp,
                        f"odometry registration failed: {odometry.matches} matches to the "
                        f"local map, fewer than Vis/MinInliers {self.params.min_inliers} agree",
                    )
                )
        else:
            status = self._track_status(frame, odometry, events)
            self.odometry_variance = (
                self.odometry_variance.larger(odometry.variance)
                if self.params.link_covariance == "largest"
                else odometry.variance
            )
            if due:
                if self.new_map_due:
                    self._begin_map()
                if odometry.new_session or self._first_of_map or self._moved(odometry.pose):
                    events += self._update_map(frame, features, odometry.pose, watch)
                else:
                    watch("vocabulary", self._rehearse, features)
            # A registered frame has a location: the first registration starts a session, which adds one.
            assert self.current_location is not None
            self.records.append(_FrameRecord(frame.index, frame.timestamp, odometry.pose, self.current_location))
            pose = self.graph.correction(self.current_location) @ odometry.pose
        metrics = {
            "stm": len(self.memory.stm),
            "wm": len(self.memory.wm),
            "ltm": len(self.memory.ltm),
            "words": len(self.vocabulary),
            "posterior_max": self.posterior_max,
            "local_map": odometry.local_map_size,
            "key_frame": float(odometry.key_frame),
        }
        events.insert(
            0,
            FrameTracked(
                frame.index,
                frame.timestamp,
                pose,
                status,
                len(features),
                odometry.matches,
                odometry.inliers,
                self.current_location if pose is not None else None,
                watch.ms,
                metrics,
            ),
        )
        return events

    def _begin_map(self) -> None:
        """A new map (Memory::incrementMapId): the next location starts a graph session of its
        own, unlinked to the previous one, and every STM location becomes a loop closure candidate."""
        self.session += 1
        self.memory.start_map()
        self.new_map_due = False

    @property
    def _first_of_map(self) -> bool:
        """No location of the current map yet (one was begun after a loss)."""
        return self.current_location is not None and self.graph.session[self.current_location] != self.session

    def _track_status(self, frame: Frame, odometry: OdometryResult, events: list[Event]) -> TrackingStatus:
        if odometry.new_session:
            self._begin_map()
            if odometry.reset:
                events.append(
                    TrackingRecovered(
                        frame.index,
                        frame.timestamp,
                        f"odometry reset after Odom/ResetCountdown "
                        f"{self.params.reset_countdown} lost frames: new map {self.session}",
                    )
                )
            self.lost = False
            return TrackingStatus.INITIALISING
        if self.lost:
            self.lost = False
            events.append(
                TrackingRecovered(
                    frame.index,
                    frame.timestamp,
                    "registered to the local map again"
                    + ("; the next location begins a new map (viewslam/NewMapOnLoss)" if self.new_map_due else ""),
                )
            )
            return TrackingStatus.RELOCALISED
        return TrackingStatus.OK

    def _detection_due(self, timestamp: float) -> bool:
        """Rtabmap/DetectionRate: at most one map update per period, on a clock that every
        frame's stamp advances, registered or lost, as the front-ends throttle every odometry
        message (rtabmap_ros ``CoreWrapper::odomUpdate``, the dataset tool's ``processData``):
        a frame that resumes tracking waits for the next tick like any other."""
        rate = self.params.detection_rate
        if rate > 0 and timestamp - self.last_tick < 1.0 / rate:
            return False
        self.last_tick = timestamp
        return True

    def _moved(self, odometry_pose: np.ndarray) -> bool:
        """RGBD/LinearUpdate, RGBD/AngularUpdate: motion since the last location."""
        assert self.current_location is not None  # asked after the session's first location
        motion = invert(self.memory.locations[self.current_location].odometry_pose) @ odometry_pose
        return bool(
            np.linalg.norm(motion[:3, 3]) >= self.params.linear_update
            or rotation_angle(motion[:3, :3]) >= self.params.angular_update
        )

    def _rehearse(self, features: Features) -> None:
        """The camera stayed: a view similar to the last location strengthens it (weight)."""
        assert self.current_location is not None  # asked after the session's first location
        last = self.memory.locations[self.current_location]
        words = self.vocabulary.quantize(features.descriptors[self._strongest(features)])
        if similarity(last.words, words) > self.params.rehearsal_similarity:
            last.weight += 1

    def _strongest(self, features: Features) -> np.ndarray:
        """Rows of the Kp/MaxFeatures strongest features, the ones quantised to words."""
        order = np.argsort(-features.responses, kind="stable")[: self.params.words_per_location]
        return np.sort(order)

    def _signature(self, features: Features) -> Features:
        """The features a new location keeps (Memory::createSignature with Mem/UseOdomFeatures):
        all of odometry's, up to Vis/MaxFeatures, for its registrations, of which only the
        Kp/MaxFeatures strongest become words; none when they are fewer than Kp/BadSignRatio
        of the mean words per STM/WM location, a bad signature that takes no part in loop
        closure detection."""
        if len(features) < self.params.bad_signature_ratio * self.vocabulary.mean_words_per_location():
            return features.subset(np.zeros(0, int))
        return features

    # -- per location ------------------------------------------------------------------

    def _update_map(self, frame: Frame, features: Features, odometry_pose: np.ndarray, watch: Stopwatch) -> list[Event]:
        """Add a location, look for a loop closure, and keep memory within its budget."""
        p = self.params
        start = time.perf_counter()
        kept = self._signature(features)
        location_id = len(self.memory.locations)
        words = watch("vocabulary", self.vocabulary.add_location, location_id, kept.descriptors, self._strongest(kept))
        location = Location(
            location_id,
            self.session,
            frame.index,
            frame.timestamp,
            odometry_pose,
            kept.keypoints,
            kept.descriptors,
            kept.points,
            words,
            *self._cloud(frame),
        )
        previous = self.current_location
        continues_chain = previous is not None and self.graph.session[previous] == self.session
        if continues_chain and previous is not None:
            self._pass_weight(self.memory.locations[previous], location)
        self.memory.add(location)
        if continues_chain and previous is not None:
            self.memory.link(previous, location_id, Link.NEIGHBOUR)
        self.edges.add_node(location_id, frame.timestamp)
        self.graph.add_location(location_id, self.session, odometry_pose, self.odometry_variance)
        self.odometry_variance = Variance()
        self.current_location = location_id
        pose = self.graph.poses[location_id]
        events: list[Event] = [
            KeyframeAdded(location_id, frame.index, frame.timestamp, pose.copy(), *self._thumbnails(frame)),
            *(
                [
                    GraphEdge(
                        frame.index,
                        previous,
                        location_id,
                        True,
                        "odometry link",
                        self.edges.kind(previous, location_id),
                        detection="odometry",
                    )
                ]
                if continues_chain and previous is not None
                else []
            ),
            MapUpdated(
                frame.index, transform_points(pose, location.cloud_points).astype(np.float32), location.cloud_colors
            ),
        ]
        detection = watch("bayes", self.detector.detect, self.memory, words) if len(words) else None
        hypothesis = detection.hypothesis if detection is not None else None
        protected, retrieved = self._immunised_near(location), []
        if hypothesis is not None:
            self.posterior_max = hypothesis.value
            if self._memory_managed:
                order, immune = watch("memory", self.memory.retrieval_order, hypothesis.location, p.max_retrieved)
                retrieved = watch("memory", self.memory.retrieve, order, p.max_retrieved)
                protected |= immune | set(retrieved)
        pending = (
            hypothesis
            if hypothesis is not None
            and detection is not None
            and self._accepts(frame, location, hypothesis, detection.states, events)
            else None
        )
        self.last_hypothesis = hypothesis.value if hypothesis is not None else 0.0
        registered: list[Registered] = []
        if p.proximity_by_space and p.local_radius > 0:
            pending = self._proximity(
                frame, location, detection.likelihood if detection else {}, pending, registered, watch, events
            )
        if pending is not None:
            old = self.memory.locations[pending.location]
            registration = self._register(frame, old, location, Link.LOOP, pending.value, watch, events)
            if registration is not None:
                registered.append(Registered(old, Link.LOOP, pending.value, registration))
        if registered:
            self._link(frame, location, registered, watch, events)
        watch("memory", self._keep_budget, protected, 1 + len(retrieved), (time.perf_counter() - start) * 1e3)
        return events

    @property
    def _memory_managed(self) -> bool:
        return self.params.memory_threshold > 0 or self.params.time_threshold > 0

    def _immunised_near(self, location: Location) -> set[int]:
        """RGBD/LocalImmunizationRatio: with memory management, the WM locations nearest the
        camera (within RGBD/LocalRadius), up to that share of WM, stay in WM; every WM
        location within the radius counts as recent (Memory::updateAge)."""
        if not self._memory_managed:
            return set()
        here = self.graph.poses[location.id][:3, 3]
        distance = {i: float(np.linalg.norm(self.graph.poses[i][:3, 3] - here)) for i in self.memory.wm}
        near = sorted(
            (d, i) for i, d in distance.items() if self.params.local_radius == 0 or d < self.params.local_radius
        )
        for _, i in reversed(near):
            self.memory.touch(i)
        budget = int(self.params.local_immunization_ratio * len(self.memory.wm))
        return {i for _, i in near[:budget]}

    def _pass_weight(self, previous: Location, location: Location) -> None:
        """Rehearsal while moving: a new location that looks like the previous one inherits its
        weight (plus one), so a place seen for long keeps one heavy node."""
        if similarity(previous.words, location.words) > self.params.rehearsal_similarity:
            location.weight = previous.weight + 1
            previous.weight = 0

    def _accepts(
        self, frame: Frame, location: Location, hypothesis: Hypothesis, states: int, events: list[Event]
    ) -> bool:
        """Rtabmap::process: the hypothesis is to be verified when the sum of the loop closure
        probabilities reaches Rtabmap/LoopThr (RGBD/AggressiveLoopThr, when lower, for a
        hypothesis in a map not joined to the current one: "not linked to previous map of that
        hypothesis"), there is more than one location to choose from, and (with
        Rtabmap/LoopRatio) it has not fallen below that share of the previous one."""
        p, value, previous = self.params, hypothesis.value, self.last_hypothesis
        threshold, name = p.loop_threshold, "Rtabmap/LoopThr"
        joined = self.graph.map_of(hypothesis.location) == self.graph.map_of(location.id)
        if not joined and p.aggressive_loop_threshold < threshold:
            threshold, name = p.aggressive_loop_threshold, "RGBD/AggressiveLoopThr"
        reason = None
        if value < threshold:
            reason = f"hypothesis {value:.2f} < {name} {threshold:g}"
        elif states <= 2:
            reason = "a single location to choose from"
        elif p.loop_ratio > 0 and previous and value < p.loop_ratio * previous:
            reason = f"hypothesis {value:.2f} < Rtabmap/LoopRatio {p.loop_ratio:g} x {previous:.2f}"
        elif p.loop_ratio > 0 and not previous:
            reason = "no previous hypothesis (Rtabmap/LoopRatio is on)"
        if reason is None:
            return True
        if value >= threshold:
            events.append(
                GraphEdge(
                    frame.index,
                    hypothesis.location,
                    location.id,
                    False,
                    reason,
                    self.edges.kind(hypothesis.location, location.id),
                    score=value,
                )
            )
        return False

    def _proximity(
        self,
        frame: Frame,
        location: Location,
        likelihood: dict[int, float],
        hypothesis: Hypothesis | None,
        registered: list[Registered],
        watch: Stopwatch,
        events: list[Event],
    ) -> Hypothesis | None:
        """RGBD/ProximityBySpace: register with nearby locations of the same map off STM, before
        the loop closure hypothesis is, as Rtabmap::process does. A registration within
        RGBD/ProximityPathFilteringRadius is kept to link; once one is, a hypothesis among the
        nearby locations is not registered itself ("Proximity detection on N is close to loop
        closure M, ignoring loop closure transform estimation"), and a link to the hypothesis
        itself is a loop closure. The registrations go to ``registered``, to be linked with the
        update's others; returns the hypothesis still to verify."""
        map_id = self.graph.map_of(location.id)
        nearby = nearby_locations(
            self.memory, self.graph.poses, location.id, lambda i: self.graph.map_of(i) == map_id, self.params
        )
        for candidate in proximity_candidates(
            self.memory, self.graph.poses, location.id, nearby, likelihood, self.params
        ):
            old = self.memory.locations[candidate]
            is_hypothesis = hypothesis is not None and candidate == hypothesis.location
            link = Link.LOOP if is_hypothesis else Link.PROXIMITY
            score = hypothesis.value if hypothesis is not None and is_hypothesis else 0.0
            registration = self._register(frame, old, location, link, score, watch, events)
            if registration is None:
                continue
            assert registration.relative is not None  # a registration that found no pose is None here
            if not within_filtering_radius(registration.relative[:3, 3], self.params):
                events.append(
                    self._edge(
                        frame,
                        old,
                        location,
                        False,
                        "registration reaches beyond RGBD/ProximityPathFilteringRadius",
                        link,
                        score,
                        registration.inliers,
                    )
                )
                continue
            if hypothesis is not None and hypothesis.location in nearby:
                if not is_hypothesis:
                    events.append(
                        self._edge(
                            frame,
                            self.memory.locations[hypothesis.location],
                            location,
                            False,
                            f"proximity link to {candidate} nearby takes its place",
                            Link.LOOP,
                            hypothesis.value,
                        )
                    )
                hypothesis = None
            registered.append(Registered(old, link, score, registration))
        return hypothesis

    def _register(
        self,
        frame: Frame,
        old: Location,
        new: Location,
        link: Link,
        score: float,
        watch: Stopwatch,
        events: list[Event],
    ) -> Registration | None:
        """The PnP registration of two locations; None (and the reason, as an event) when it fails."""
        registration = watch("verification", register, old, new, self.camera, self.params, self.tree_seeds)
        if registration.relative is None:
            events.append(self._edge(frame, old, new, False, registration.rejected, link, score, registration.inliers))
            return None
        return registration

    def _link(
        self, frame: Frame, new: Location, registered: list[Registered], watch: Stopwatch, events: list[Event]
    ) -> None:
        """Add the update's registered links to the graph, which joins maps and keeps or rejects
        the others together (:meth:`LocationGraph.close_loops`)."""
        outcomes = watch(
            "optimisation", self.graph.close_loops, [(link.old.id, new.id, *link.relation) for link in registered]
        )
        for link, outcome in zip(registered, outcomes, strict=True):
            events.append(
                self._edge(frame, link.old, new, outcome.accepted, outcome.reason, link.kind, link.score, link.inliers)
            )
        accepted = [link for link, outcome in zip(registered, outcomes, strict=True) if outcome.accepted]
        if not accepted:
            return
        for link in accepted:
            self.memory.link(link.old.id, new.id, link.kind)
        optimised = next((outcome for outcome in outcomes if not outcome.joined_maps), outcomes[0])
        ids = np.array(sorted(self.graph.poses))
        events.append(
            GraphOptimized(
                frame.index,
                ids,
                np.stack([self.graph.poses[i] for i in ids]),
                optimised.error_before,
                optimised.error_after,
            )
        )
        events.append(watch("optimisation", self._rebuilt_map, frame.index))

    def _edge(
        self,
        frame: Frame,
        old: Location,
        new: Location,
        accepted: bool,
        reason: str,
        link: Link,
        score: float,
        inliers: int = 0,
    ) -> GraphEdge:
        return GraphEdge(
            frame.index,
            old.id,
            new.id,
            accepted,
            reason,
            self.edges.kind(old.id, new.id),
            score,
            inliers,
            DETECTION[link],
        )

    def _keep_budget(self, protected: set[int], added: int, elapsed_ms: float) -> None:
        """Rtabmap/TimeThr and Rtabmap/MemoryThr: when the update took too long or WM holds too
        many locations, (added + 1) locations go to LTM (Memory::forget)."""
        p = self.params
        if (p.time_threshold > 0 and elapsed_ms > p.time_threshold) or (
            p.memory_threshold > 0 and len(self.memory.wm) > p.memory_threshold
        ):
            self.memory.forget(added + 1, protected)

    # -- map and images ----------------------------------------------------------------

    def _cloud(self, frame: Frame) -> tuple[np.ndarray, np.ndarray]:
        points, pixels = self.camera.depth_to_points(frame.depth, self.cloud_step)
        return points.astype(np.float32), frame.rgb[pixels[:, 0], pixels[:, 1]]

    @staticmethod
    def _thumbnails(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
        return thumbnail(frame.rgb), thumbnail(frame.depth, nearest=True)

    def _rebuilt_map(self, frame_index: int) -> MapUpdated:
        """Every location's cloud at its optimised pose, subsampled to MAP_POINTS_LIMIT."""
        locations = [self.memory.locations[i] for i in sorted(self.memory.locations)]
        return rebuilt_map(
            frame_index,
            ((self.graph.poses[loc.id], loc.cloud_points, loc.cloud_colors) for loc in locations),
            MAP_POINTS_LIMIT,
        )

    # -- end of run --------------------------------------------------------------------

    def finish(self) -> list[Event]:
        """Every frame with odometry, moved by its location's optimised correction."""
        if not self.records:
            return [TrajectoryFinal(np.zeros(0, int), np.zeros(0), np.zeros((0, 4, 4)), np.zeros((0, 4, 4)))]
        corrections = {i: self.graph.correction(i) for i in {r.location for r in self.records}}
        odometry = np.stack([r.odometry_pose for r in self.records])
        poses = np.stack([corrections[r.location] for r in self.records]) @ odometry
        return [
            TrajectoryFinal(
                np.array([r.index for r in self.records]),
                np.array([r.timestamp for r in self.records]),
                poses,
                odometry,
            )
        ]
