"""Pipeline events to Rerun: one :class:`PipelineRecorder` per pipeline, under its own roots.

The recorder is a sink for :func:`viewer_slam.runs.service.score_run`. The session
calls :meth:`PipelineRecorder.begin_frame` as each frame is read, which sets the ``frame``
and ``time`` timelines for every event that frame produces. Poses and points arrive in the
pipeline's map frame and are logged under ``world/<pipeline>``, whose transform to
``world`` is set once the run has been evaluated.
"""

import re
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
import rerun as rr

from .. import palette
from ..dataset.frame import Frame
from ..geometry.camera import Camera
from ..geometry.trajectory import Trajectory
from ..pipelines.edges import EdgeKind
from ..pipelines.events import (
    Event,
    FeatureMatches,
    FrameTracked,
    GraphEdge,
    GraphOptimized,
    KeyframeAdded,
    MapUpdated,
    TrackingRecovered,
    TrackingStatus,
    TrajectoryFinal,
)
from . import layout
from .blueprint import LOST_BAND, LOST_BAND_WIDTH
from .budget import SnapshotBudget
from .fit import log_rows
from .frame_columns import HeldRows
from .images import depth_png, jpeg, jpeg_bytes
from .sizes import SceneSizes, extent, scene_sizes
from .voxel_map import VoxelMap

KEYFRAME_DEPTH_STEP = 4  # keyframe depth images are kept at a quarter of the resolution
MAX_MATCHES_DRAWN = 150
# Bytes per frame that each growing snapshot may spend on being re-logged (see SnapshotBudget).
MAP_BYTES_PER_FRAME = 3072
KEYFRAMES_BYTES_PER_FRAME = 512
LOOP_CLOSURES_BYTES_PER_FRAME = 512
EDGES_BYTES_PER_FRAME = 512
DEPTH_BYTES_PER_FRAME = 1536
THUMBNAIL_BYTES_PER_FRAME = 1024
# A map snapshot is due once the frames have paid for this share of it, and is thinned to what
# they paid: the map grows visibly while scrubbing, for the bytes of rarer whole snapshots.
MAP_MIN_SHARE = 0.1
# Approximate bytes per element of each snapshot: positions, colours, radii, labels.
MAP_POINT_BYTES = 16
KEYFRAME_BYTES = 24
EDGE_BYTES = 36
# Re-log the frustum when the scene (seen so far, without groundtruth) has grown by this factor.
FRUSTUM_RESIZE_FACTOR = 1.25
# The series the evaluation writes back once a run has ended (recording/timelines.py).
EVALUATION_SERIES = ("ate", "ate_segments", "rpe_trans", "rpe_rot", "coverage")
# The tracker's own per-frame counts (FrameTracked fields) and their line widths.
TRACKER_COUNTS = {"features": 1.0, "matches": 1.0, "inliers": 2.0}
# Line widths and point radii on screen (ui points): legible at any scene scale.
TRAJECTORY_WIDTH = 2.0
ODOMETRY_WIDTH = 1.0
FRUSTUM_WIDTH = 1.5
LOST_FRUSTUM_WIDTH = 1.0
RECENT_LOOP_WIDTH = 1.5
OLD_LOOP_WIDTH = 0.75
EDGE_WIDTH = 0.5
MATCH_WIDTH = 1.0
MAP_POINT_RADIUS = 1.25


def set_frame_time(stream: rr.RecordingStream, index: int, timestamp: float) -> None:
    stream.set_time("frame", sequence=int(index))
    stream.set_time("time", timestamp=float(timestamp))


def log_frame_image(stream: rr.RecordingStream, frame: Frame) -> None:
    """The input colour image, once per frame for all pipelines (their matches overlay it)."""
    stream.log(layout.CAMERA_IMAGE, jpeg(frame.rgb))


def log_world(stream: rr.RecordingStream, groundtruth: Trajectory | None) -> None:
    """``world`` is the groundtruth frame, z up as TUM's motion capture (and the synthetic scenes)."""
    stream.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    if groundtruth is None or len(groundtruth.positions) < 2:
        return
    stream.log(
        layout.GROUNDTRUTH,
        rr.LineStrips3D([groundtruth.positions], colors=[palette.GROUNDTRUTH.rgb], radii=rr.Radius.ui_points(2.0)),
        static=True,
    )


def pinhole(camera: Camera, color, depth: float, width: float = FRUSTUM_WIDTH) -> rr.Pinhole:
    """A frustum ``depth`` metres deep (see :mod:`.sizes`)."""
    return rr.Pinhole(
        image_from_camera=camera.K,
        resolution=[camera.width, camera.height],
        camera_xyz=rr.ViewCoordinates.RDF,
        image_plane_distance=depth,
        color=color,
        line_width=float(np.asarray(rr.Radius.ui_points(width))),
    )


def lost_colour(colour: palette.Colour) -> tuple[int, int, int]:
    """A run's colour while it is lost: its own hue, dimmed (not a red shared by every run)."""
    return palette.faded(colour, share=0.45, towards=40)


def transform(pose: np.ndarray) -> rr.Transform3D:
    return rr.Transform3D(translation=pose[:3, 3], mat3x3=pose[:3, :3])


def evenly_spaced(count: int, limit: int) -> np.ndarray:
    """At most ``limit`` indices spread evenly over ``range(count)`` (deterministic thinning)."""
    if count <= limit:
        return np.arange(count)
    return np.round(np.linspace(0, count - 1, limit)).astype(int)


def loop_closure_line(edges: list[GraphEdge], verdict: str) -> str:
    """One log message for all the loop-closure hypotheses of one frame that share a verdict:
    for each, its keyframes, how it was found and the pipeline's reason, with the score and
    the inlier count where the reason does not already say them."""

    def detail(edge: GraphEdge) -> str:
        parts = [edge.detection, edge.reason]
        if edge.score != edge.inliers:
            parts.append(f"score {edge.score:.3g}")
        if not re.search(r"\d+ inliers", edge.reason):
            parts.append(f"{edge.inliers} inliers")
        return f"KF{edge.from_keyframe} -> KF{edge.to_keyframe} ({', '.join(parts)})"

    noun = "loop closure" if len(edges) == 1 else f"{len(edges)} loop closures"
    return f"{noun} {verdict}: {'; '.join(detail(edge) for edge in edges)}"


def log_run_styles(stream: rr.RecordingStream, name: str, colour: palette.Colour) -> None:
    """The static styles of a run's evaluation series (ATE, segment ATE, RPE, coverage), its lost
    band and its tracking-state timeline: the same for a pipeline and for a trajectory file."""
    for series in EVALUATION_SERIES:
        stream.log(
            layout.metric(name, series), rr.SeriesLines(colors=[colour.rgb], names=[name], widths=[2.0]), static=True
        )
    stream.log(
        layout.metric(name, LOST_BAND),
        rr.SeriesLines(colors=[lost_colour(colour)], names=[f"{name}: no pose"], widths=[LOST_BAND_WIDTH]),
        static=True,
    )
    stream.log(
        layout.metric(name, "tracking_state"),
        rr.StateConfiguration(
            values=list(palette.STATUS),
            labels=list(palette.STATUS),
            colors=[status.rgb for status in palette.STATUS.values()],
        ),
        static=True,
    )


class PipelineRecorder:
    """Turns one pipeline's events into Rerun data (see DESIGN.md, "Rerun recording").

    Sizes come from ``scene_extent`` (the groundtruth's, see :mod:`.sizes`), else from the
    poses seen so far. Every batch of instances goes through :meth:`_log_instances`, which
    sends a Clear rather than an empty batch; the recorder never sends columns.
    Each accepted loop closure is also logged once, bright, at its frame under
    ``loop_closures/recent``, which the 3D view shows over a window of the last second;
    all of them are drawn dim under ``loop_closures``.
    ``tracker_counts`` False (an imported estimate, which measures no features, matches or
    inliers) leaves those series out rather than plotting zeros.
    """

    def __init__(
        self,
        stream: rr.RecordingStream,
        name: str,
        camera: Camera,
        colour: palette.Colour,
        scene_extent: float | None = None,
        tracker_counts: bool = True,
    ):
        self.stream = stream
        self.tracker_counts = tracker_counts
        self.name = name
        self.camera = camera
        self.colour = colour
        self.frame_indices: list[int] = []
        self.frame_timestamps: list[float] = []
        self.status: str | None = None
        self._scene_extent = scene_extent
        self._seen = np.zeros((0, 3))  # corners of the bounding box of the poses seen
        self._frustum_depth: float | None = None
        self._last_pose: np.ndarray | None = None
        self._frame: Frame | None = None
        self._held = HeldRows(stream)  # the per-frame numbers, poses and matches, sent as columns
        self._matched_frame: int | None = None
        self._keyframes: dict[int, np.ndarray] = {}
        self._loops: list[GraphEdge] = []
        self._edges: dict[EdgeKind, list[GraphEdge]] = {EdgeKind.SEQUENTIAL: [], EdgeKind.LOCAL: []}
        self._unlogged_loops: list[GraphEdge] = []
        self._map = VoxelMap()
        self._map_budget = SnapshotBudget(MAP_BYTES_PER_FRAME, min_share=MAP_MIN_SHARE)
        self._keyframes_budget = SnapshotBudget(KEYFRAMES_BYTES_PER_FRAME)
        self._loops_budget = SnapshotBudget(LOOP_CLOSURES_BYTES_PER_FRAME)
        self._edges_budget = SnapshotBudget(EDGES_BYTES_PER_FRAME)
        self._depth_budget = SnapshotBudget(DEPTH_BYTES_PER_FRAME)
        self._thumbnail_budget = SnapshotBudget(THUMBNAIL_BYTES_PER_FRAME)
        # Each handler takes the event type it is keyed by.
        self._handlers: dict[type, Callable[[Any], None]] = {
            FrameTracked: self._frame_tracked,
            KeyframeAdded: self._keyframe_added,
            FeatureMatches: self._feature_matches,
            GraphEdge: self._graph_edge,
            GraphOptimized: self._graph_optimized,
            MapUpdated: self._map_updated,
            TrackingRecovered: self._tracking_recovered,
            TrajectoryFinal: self._trajectory_final,
        }
        self._log_styles()

    def begin_frame(self, frame: Frame) -> None:
        """Called as ``frame`` is read: the events that follow belong to it."""
        self._log_loop_closure_lines()  # of the frame before, at its time
        self._held.next_frame()
        self._frame = frame
        set_frame_time(self.stream, frame.index, frame.timestamp)

    def flush(self) -> None:
        """Send the rows still held; the session calls it when the run ends, however it ends."""
        self._held.flush()

    def __call__(self, event: Event) -> None:
        """Record ``event``. A TrackingLost is not logged here: its one log line comes once the
        run has ended, with the cause the diagnosis measured (recording/loss_causes.py)."""
        handler = self._handlers.get(type(event))
        if handler is not None:
            handler(event)

    @property
    def sizes(self) -> SceneSizes:
        return scene_sizes(self._scene_extent if self._scene_extent is not None else extent(self._seen))

    def _log(self, path: str, *archetypes, static: bool = False) -> None:
        for archetype in archetypes:
            self.stream.log(path, archetype, static=static)

    def _log_instances(self, path: str, instances, make, static: bool = False) -> None:
        """``make(instances)`` at ``path``, or a Clear of ``path`` when there are none: an empty
        batch would say nothing the Clear does not, and no chunk of the recording is empty."""
        self._log(path, make(instances) if len(instances) else rr.Clear(recursive=False), static=static)

    def _hold(self, path: str, row: Callable[..., None], logged: Callable[[], Any], *values: Any) -> None:
        """A row of the current frame at ``path``: ``row(path, frame, timestamp, *values)`` of
        :class:`HeldRows`, sent later as a column; before any frame has begun (no frame to stamp
        it with), the archetype ``logged()`` logged at once."""
        if self._frame is None:
            self._log(path, logged())
        else:
            row(path, self._frame.index, self._frame.timestamp, *values)

    def _scalar(self, path: str, value: float) -> None:
        self._hold(path, self._held.scalar, lambda: rr.Scalars(float(value)), value)

    def _text(self, message: str, level: rr.TextLogLevel) -> None:
        """A log message, in rows that the log view shows whole; the pipeline leads the text since
        log views truncate the entity path."""
        for row in log_rows(f"{self.name}: {message}"):
            self._log(layout.text_log(self.name), rr.TextLog(row, level=level))

    def _log_styles(self) -> None:
        name, rgb = self.name, self.colour.rgb
        log_run_styles(self.stream, name, self.colour)
        self._log(
            layout.metric(name, "graph_error"), rr.SeriesLines(colors=[rgb], names=[name], widths=[2.0]), static=True
        )
        for series, width in TRACKER_COUNTS.items() if self.tracker_counts else ():
            self._log(
                layout.metric(name, series),
                rr.SeriesLines(colors=[rgb], names=[f"{name} {series}"], widths=[width]),
                static=True,
            )
        self._log(layout.matches(name), rr.LineStrips2D.from_fields(colors=[palette.INLIER.rgb]), static=True)
        self._log(
            f"{layout.matches(name)}/outliers", rr.LineStrips2D.from_fields(colors=[palette.OUTLIER.rgb]), static=True
        )

    # --- per frame ----------------------------------------------------------------------

    def _frame_tracked(self, event: FrameTracked) -> None:
        self.frame_indices.append(event.frame_index)
        self.frame_timestamps.append(event.timestamp)
        if event.pose is not None:
            seen = np.concatenate([self._seen, event.pose[None, :3, 3]])
            self._seen = np.stack([seen.min(axis=0), seen.max(axis=0)])
        self._log_state_and_frustum(event.status)
        pose = event.pose
        if pose is not None:
            self._last_pose = pose
            self._hold(layout.camera(self.name), self._held.transform, lambda: transform(pose), pose)
        if self._matched_frame != event.frame_index:
            self._hold(layout.matches(self.name), self._held.clear, lambda: rr.Clear(recursive=True), True)
        counts = {series: getattr(event, series) for series in TRACKER_COUNTS} if self.tracker_counts else {}
        for series, value in {**counts, **event.metrics}.items():
            self._scalar(layout.metric(self.name, series), value)
        for stage, ms in event.timings_ms.items():
            self._scalar(layout.metric(self.name, f"time/{stage}"), ms)
        self._log_due_snapshots(event.frame_index)

    def _log_state_and_frustum(self, status: TrackingStatus) -> None:
        """The state when it changes; the frustum then (red while lost) and when the scene has grown."""
        depth = self.sizes.frustum_depth
        resized = self._frustum_depth is not None and not (
            1 / FRUSTUM_RESIZE_FACTOR < depth / self._frustum_depth < FRUSTUM_RESIZE_FACTOR
        )
        changed = status.value != self.status
        if changed:
            self.status = status.value
            self._log(layout.metric(self.name, "tracking_state"), rr.StateChange(state=[status.value]))
        if changed or resized:
            self._frustum_depth = depth
            lost = status is TrackingStatus.LOST
            self._log(
                layout.camera(self.name),
                pinhole(self.camera, lost_colour(self.colour), depth, LOST_FRUSTUM_WIDTH)
                if lost
                else pinhole(self.camera, self.colour.rgb, depth),
            )
        if changed:  # while lost, a label at the last pose says whose frustum it is
            last_pose = self._last_pose
            self._log(
                layout.lost_label(self.name),
                rr.Points3D(
                    [last_pose[:3, 3]],
                    colors=[self.colour.rgb],
                    radii=rr.Radius.ui_points(3.0),
                    labels=[f"{self.name} lost"],
                    show_labels=True,
                )
                if status is TrackingStatus.LOST and last_pose is not None
                else rr.Clear(recursive=False),
            )

    def _feature_matches(self, event: FeatureMatches) -> None:
        """Lines from each keypoint to its match, inliers and outliers apart, thinned evenly."""
        self._matched_frame = event.frame_index
        inliers = np.asarray(event.inlier_mask, dtype=bool)
        segments = np.stack([event.points_current, event.points_reference], axis=1).astype(np.float32)
        for path, subset in (
            (layout.matches(self.name), segments[inliers]),
            (f"{layout.matches(self.name)}/outliers", segments[~inliers]),
        ):
            self._hold_segments(path, subset[evenly_spaced(len(subset), MAX_MATCHES_DRAWN // 2)])

    def _hold_segments(self, path: str, segments: np.ndarray) -> None:
        """2D line segments at ``path``, or a Clear when there are none (as :meth:`_log_instances`), held."""
        radius = rr.Radius.ui_points(MATCH_WIDTH)
        if len(segments):
            self._hold(path, self._held.segments, lambda: rr.LineStrips2D(segments, radii=radius), segments, radius)
        else:
            self._hold(path, self._held.clear, lambda: rr.Clear(recursive=False), False)

    def _tracking_recovered(self, event: TrackingRecovered) -> None:
        self._text(f"tracking recovered ({event.reason})", rr.TextLogLevel.WARN)

    # --- graph: keyframes, edges, optimisation ------------------------------------------

    def _keyframe_added(self, event: KeyframeAdded) -> None:
        self._keyframes[event.keyframe_id] = event.pose[:3, 3].copy()
        self._keyframes_budget.dirty = True
        depth = event.depth
        if depth is None and self._frame is not None and self._frame.index == event.frame_index:
            depth = self._frame.depth
        if depth is None:
            return
        small = depth[::KEYFRAME_DEPTH_STEP, ::KEYFRAME_DEPTH_STEP]
        png = depth_png(small)
        self._depth_budget.dirty = True
        if self._depth_budget.due(event.frame_index, len(png)):
            self._log(
                layout.latest_keyframe(self.name),
                transform(event.pose),
                pinhole(self.camera.scaled(small.shape[1], small.shape[0]), self.colour.rgb, self.sizes.frustum_depth),
            )
            self._log(
                f"{layout.latest_keyframe(self.name)}/depth",
                rr.EncodedDepthImage(png, media_type="image/png", meter=1000.0, colormap="turbo"),
            )
            self._depth_budget.logged(event.frame_index)
            self._log_thumbnail(event, small.shape)

    def _log_thumbnail(self, event: KeyframeAdded, shape: tuple[int, ...]) -> None:
        """The keyframe's image (the pipeline's thumbnail), drawn inside its frustum in the 3D
        view at the depth's resolution, when its own byte budget allows."""
        if event.image is None:
            return
        encoded = jpeg_bytes(cv2.resize(event.image, (shape[1], shape[0]), interpolation=cv2.INTER_AREA))
        self._thumbnail_budget.dirty = True
        if self._thumbnail_budget.due(event.frame_index, len(encoded)):
            self._log(
                f"{layout.latest_keyframe(self.name)}/thumbnail",
                rr.EncodedImage(contents=encoded, media_type="image/jpeg"),
            )
            self._thumbnail_budget.logged(event.frame_index)

    def _graph_edge(self, event: GraphEdge) -> None:
        """Loop closures (accepted or not) are drawn and logged; other accepted edges only drawn."""
        if event.kind == EdgeKind.LOOP:
            self._loops.append(event)
            self._loops_budget.dirty = True
            self._unlogged_loops.append(event)
            if event.accepted:  # drawn once, at its frame; the 3D view shows the last second of them
                self._log_lines(
                    layout.recent_loop_closures(self.name), [event], palette.ACCEPTED.rgb, RECENT_LOOP_WIDTH
                )
        elif event.accepted:
            self._edges[event.kind].append(event)
            self._edges_budget.dirty = True

    def _log_loop_closure_lines(self) -> None:
        """At most one line per verdict for the loop closures of the current frame."""
        for accepted, verdict, level in (
            (True, "accepted", rr.TextLogLevel.INFO),
            (False, "rejected", rr.TextLogLevel.DEBUG),
        ):
            edges = [edge for edge in self._unlogged_loops if edge.accepted == accepted]
            if edges:
                self._text(loop_closure_line(edges, verdict), level)
        self._unlogged_loops = []

    def _graph_optimized(self, event: GraphOptimized) -> None:
        for keyframe_id, pose in zip(np.asarray(event.keyframe_ids).tolist(), event.poses):
            self._keyframes[keyframe_id] = pose[:3, 3].copy()
        self._keyframes_budget.dirty = True
        self._loops_budget.dirty |= bool(self._loops)  # their ends move with the keyframes
        self._edges_budget.dirty |= any(self._edges.values())
        self._scalar(layout.metric(self.name, "graph_error"), event.error_after)

    def _map_updated(self, event: MapUpdated) -> None:
        self._map.add(event)
        self._map_budget.dirty = True

    # --- growing snapshots --------------------------------------------------------------

    def _log_due_snapshots(self, frame_index: int, final: bool = False) -> None:
        """Re-log keyframes, edges and map when their budget allows (always at the end)."""
        snapshots = (
            (self._keyframes_budget, len(self._keyframes) * KEYFRAME_BYTES, self._log_keyframes),
            (self._loops_budget, len(self._loops) * EDGE_BYTES, self._log_loop_closures),
            (self._edges_budget, sum(map(len, self._edges.values())) * EDGE_BYTES, self._log_edges),
        )
        for budget, size, log in snapshots:
            if budget.dirty and (final or budget.due(frame_index, size)):
                log()
                budget.logged(frame_index)
        size = self._map.size_estimate * MAP_POINT_BYTES
        if self._map_budget.dirty and (final or self._map_budget.due(frame_index, size)):
            self._log_map(1.0 if final else self._map_budget.share(frame_index, size))
            self._map_budget.logged(frame_index)

    def _log_keyframes(self) -> None:
        ids = sorted(self._keyframes)
        radius = self.sizes.keyframe_radius
        self._log_instances(
            layout.keyframes(self.name),
            ids,
            lambda ids: rr.Points3D(
                [self._keyframes[i] for i in ids],
                colors=[self.colour.rgb],
                radii=radius,
                labels=[f"KF{i}" for i in ids],
                show_labels=False,
            ),
        )

    def _segments(self, edges: list[GraphEdge]) -> list[list[np.ndarray]]:
        return [
            [self._keyframes[edge.from_keyframe], self._keyframes[edge.to_keyframe]]
            for edge in edges
            if edge.from_keyframe in self._keyframes and edge.to_keyframe in self._keyframes
        ]

    def _log_lines(self, path: str, edges: list[GraphEdge], colour, radius: float) -> None:
        self._log_instances(
            path,
            self._segments(edges),
            lambda segments: rr.LineStrips3D(segments, colors=[colour], radii=rr.Radius.ui_points(radius)),
        )

    def _log_loop_closures(self) -> None:
        """All accepted closures as thin dim green segments (the recent ones are drawn bright apart);
        rejected ones, often many, apart in thin red."""
        self._log_lines(
            layout.loop_closures(self.name),
            [loop for loop in self._loops if loop.accepted],
            palette.faded(palette.ACCEPTED, share=0.5, towards=50),
            OLD_LOOP_WIDTH,
        )
        self._log_lines(
            layout.rejected_loop_closures(self.name),
            [loop for loop in self._loops if not loop.accepted],
            palette.REJECTED.rgb,
            0.5,
        )

    def _log_edges(self) -> None:
        """Sequential and local edges: thin and faded, beneath the trajectories and loop closures."""
        for kind, edges in self._edges.items():
            self._log_lines(layout.edges(self.name, kind.value), edges, palette.faded(self.colour), EDGE_WIDTH)

    def _log_map(self, share: float) -> None:
        """The map, evenly thinned to ``share`` of its points (see MAP_MIN_SHARE)."""
        points, colors = self._map.points, self._map.colors
        kept = evenly_spaced(len(points), round(share * len(points)))
        self._log_instances(
            layout.map_cloud(self.name),
            kept,
            lambda kept: rr.Points3D(
                points[kept].astype(np.float32), colors=colors[kept], radii=rr.Radius.ui_points(MAP_POINT_RADIUS)
            ),
        )

    # --- end of run ---------------------------------------------------------------------

    def _trajectory_final(self, event: TrajectoryFinal) -> None:
        """Final snapshots and log lines, then the final trajectory and raw odometry as static strips."""
        self._log_loop_closure_lines()
        self._log_due_snapshots(self.frame_indices[-1] if self.frame_indices else 0, final=True)
        segments = [segment for segment in self._tracked_segments(event.frame_indices) if len(segment) > 1]
        poses = np.asarray(event.poses).reshape(-1, 4, 4)
        self._log_instances(
            layout.trajectory(self.name),
            segments,
            lambda segments: rr.LineStrips3D(
                [poses[segment, :3, 3] for segment in segments],
                colors=[self.colour.rgb],
                radii=rr.Radius.ui_points(TRAJECTORY_WIDTH),
            ),
            static=True,
        )
        if event.odometry_poses is not None and len(event.odometry_poses):
            odometry = np.asarray(event.odometry_poses).reshape(-1, 4, 4)
            self._log_instances(
                layout.odometry(self.name),
                segments,
                lambda segments: rr.LineStrips3D(
                    [odometry[segment, :3, 3] for segment in segments],
                    colors=[palette.faded(self.colour)],
                    radii=rr.Radius.ui_points(ODOMETRY_WIDTH),
                ),
                static=True,
            )
        self.flush()

    def _tracked_segments(self, posed_frames: np.ndarray) -> list[np.ndarray]:
        """Index runs of consecutively processed frames with a pose: no line bridges a loss."""
        processed = np.searchsorted(self.frame_indices, posed_frames)
        breaks = np.flatnonzero(np.diff(processed) > 1) + 1
        return np.split(np.arange(len(posed_frames)), breaks)
