"""Pipeline events to Rerun: one :class:`PipelineRecorder` per pipeline, under its own roots.

The recorder is a sink for :func:`viewer_slam.pipelines.run.run_pipeline`. The session
calls :meth:`PipelineRecorder.begin_frame` as each frame is read, which sets the ``frame``
and ``time`` timelines for every event that frame produces. Poses and points arrive in the
pipeline's map frame and are logged under ``world/<pipeline>``, whose transform to
``world`` is set once the run has been evaluated.
"""

import numpy as np
import rerun as rr

from ..dataset.frame import Frame
from ..geometry.camera import Camera
from ..geometry.trajectory import Trajectory
from ..pipelines.edges import EdgeKind
from ..pipelines.events import (Event, FeatureMatches, FrameTracked, GraphEdge, GraphOptimized, KeyframeAdded,
                                MapUpdated, TrackingLost, TrackingRecovered, TrackingStatus, TrajectoryFinal)
from . import layout
from .budget import SnapshotBudget
from .images import depth_png, jpeg
from .voxel_map import VoxelMap

FRUSTUM_DEPTH_M = 0.15
KEYFRAME_DEPTH_STEP = 4  # keyframe depth images are kept at a quarter of the resolution
MAX_MATCHES_DRAWN = 150
# Bytes per frame that each growing snapshot may spend on being re-logged (see SnapshotBudget).
MAP_BYTES_PER_FRAME = 3072
KEYFRAMES_BYTES_PER_FRAME = 512
LOOP_CLOSURES_BYTES_PER_FRAME = 512
DEPTH_BYTES_PER_FRAME = 1536
# Approximate bytes per element of each snapshot: positions, colours, radii, labels.
MAP_POINT_BYTES = 16
KEYFRAME_BYTES = 24
LOOP_CLOSURE_BYTES = 36


def set_frame_time(stream: rr.RecordingStream, index: int, timestamp: float) -> None:
    stream.set_time("frame", sequence=int(index))
    stream.set_time("time", timestamp=float(timestamp))


def log_frame_image(stream: rr.RecordingStream, frame: Frame) -> None:
    """The input colour image, once per frame for all pipelines (their matches overlay it)."""
    stream.log(layout.CAMERA_IMAGE, jpeg(frame.rgb))


def log_world(stream: rr.RecordingStream, groundtruth: Trajectory | None) -> None:
    """``world`` is the groundtruth frame, z up as TUM's motion capture (and the synthetic scenes)."""
    stream.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    if groundtruth is None:
        return
    stream.log(layout.GROUNDTRUTH, rr.LineStrips3D([groundtruth.positions], colors=[layout.GROUNDTRUTH_COLOR],
                                                   radii=rr.Radius.ui_points(2.0)), static=True)


def pinhole(camera: Camera, color) -> rr.Pinhole:
    return rr.Pinhole(image_from_camera=camera.K, resolution=[camera.width, camera.height],
                      camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=FRUSTUM_DEPTH_M, color=color,
                      line_width=rr.Radius.ui_points(1.5))


def transform(pose: np.ndarray) -> rr.Transform3D:
    return rr.Transform3D(translation=pose[:3, 3], mat3x3=pose[:3, :3])


def evenly_spaced(count: int, limit: int) -> np.ndarray:
    """At most ``limit`` indices spread evenly over ``range(count)`` (deterministic thinning)."""
    if count <= limit:
        return np.arange(count)
    return np.round(np.linspace(0, count - 1, limit)).astype(int)


class PipelineRecorder:
    """Turns one pipeline's events into Rerun data (see DESIGN.md, "Rerun recording")."""

    def __init__(self, stream: rr.RecordingStream, name: str, camera: Camera, color: tuple[int, int, int]):
        self.stream = stream
        self.name = name
        self.camera = camera
        self.color = color
        self.frame_indices: list[int] = []
        self.frame_timestamps: list[float] = []
        self.status: str | None = None
        self._frame: Frame | None = None
        self._matched_frame: int | None = None
        self._keyframes: dict[int, np.ndarray] = {}
        self._loops: list[GraphEdge] = []
        self._map = VoxelMap()
        self._map_budget = SnapshotBudget(MAP_BYTES_PER_FRAME)
        self._keyframes_budget = SnapshotBudget(KEYFRAMES_BYTES_PER_FRAME)
        self._loops_budget = SnapshotBudget(LOOP_CLOSURES_BYTES_PER_FRAME)
        self._depth_budget = SnapshotBudget(DEPTH_BYTES_PER_FRAME)
        self._handlers = {
            FrameTracked: self._frame_tracked, KeyframeAdded: self._keyframe_added,
            FeatureMatches: self._feature_matches, GraphEdge: self._graph_edge,
            GraphOptimized: self._graph_optimized, MapUpdated: self._map_updated,
            TrackingLost: self._tracking_lost, TrackingRecovered: self._tracking_recovered,
            TrajectoryFinal: self._trajectory_final,
        }
        self._log_styles()

    def begin_frame(self, frame: Frame) -> None:
        """Called as ``frame`` is read: the events that follow belong to it."""
        self._frame = frame
        set_frame_time(self.stream, frame.index, frame.timestamp)

    def __call__(self, event: Event) -> None:
        self._handlers[type(event)](event)

    def _log(self, path: str, *archetypes, static: bool = False) -> None:
        for archetype in archetypes:
            self.stream.log(path, archetype, static=static)

    def _text(self, message: str, level: str) -> None:
        """A log line; the pipeline leads the text since log views truncate the entity path."""
        self._log(layout.text_log(self.name), rr.TextLog(f"{self.name}: {message}", level=level))

    def _log_styles(self) -> None:
        name, color = self.name, self.color
        for series in ("ate", "rpe_trans", "rpe_rot", "coverage", "graph_error"):
            self._log(layout.metric(name, series), rr.SeriesLines(colors=[color], names=[name], widths=[2.0]),
                      static=True)
        for series, width in (("features", 1.0), ("matches", 1.0), ("inliers", 2.0)):
            self._log(layout.metric(name, series),
                      rr.SeriesLines(colors=[color], names=[f"{name} {series}"], widths=[width]), static=True)
        self._log(layout.metric(name, "tracking_state"),
                  rr.StateConfiguration(values=list(layout.STATUS_COLORS), labels=list(layout.STATUS_COLORS),
                                        colors=list(layout.STATUS_COLORS.values())), static=True)
        self._log(layout.matches(name), rr.LineStrips2D.from_fields(colors=[layout.INLIER_COLOR]), static=True)
        self._log(f"{layout.matches(name)}/outliers", rr.LineStrips2D.from_fields(colors=[layout.OUTLIER_COLOR]),
                  static=True)

    # --- per frame ----------------------------------------------------------------------

    def _frame_tracked(self, event: FrameTracked) -> None:
        self.frame_indices.append(event.frame_index)
        self.frame_timestamps.append(event.timestamp)
        status = event.status.value
        if status != self.status:
            self.status = status
            self._log(layout.metric(self.name, "tracking_state"), rr.StateChange(state=[status]))
            frustum = layout.LOST_COLOR if event.status is TrackingStatus.LOST else self.color
            self._log(layout.camera(self.name), pinhole(self.camera, frustum))
        if event.pose is not None:
            self._log(layout.camera(self.name), transform(event.pose))
        if self._matched_frame != event.frame_index:
            self._log(layout.matches(self.name), rr.Clear(recursive=True))
        counts = {"features": event.features, "matches": event.matches, "inliers": event.inliers}
        for series, value in {**counts, **event.metrics}.items():
            self._log(layout.metric(self.name, series), rr.Scalars(float(value)))
        for stage, ms in event.timings_ms.items():
            self._log(layout.metric(self.name, f"time/{stage}"), rr.Scalars(float(ms)))
        self._log_due_snapshots(event.frame_index)

    def _feature_matches(self, event: FeatureMatches) -> None:
        """Lines from each keypoint to its match, inliers and outliers apart, thinned evenly."""
        self._matched_frame = event.frame_index
        inliers = np.asarray(event.inlier_mask, dtype=bool)
        segments = np.stack([event.points_current, event.points_reference], axis=1).astype(np.float32)
        for path, subset in ((layout.matches(self.name), segments[inliers]),
                             (f"{layout.matches(self.name)}/outliers", segments[~inliers])):
            drawn = subset[evenly_spaced(len(subset), MAX_MATCHES_DRAWN // 2)]
            self._log(path, rr.LineStrips2D(drawn, radii=rr.Radius.ui_points(1.0)))

    def _tracking_lost(self, event: TrackingLost) -> None:
        self._text(f"tracking lost ({event.reason})", rr.TextLogLevel.WARN)

    def _tracking_recovered(self, event: TrackingRecovered) -> None:
        self._text(f"tracking recovered ({event.reason})", rr.TextLogLevel.INFO)

    # --- graph: keyframes, loop closures, optimisation ----------------------------------

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
            self._log(layout.latest_keyframe(self.name), transform(event.pose),
                      pinhole(self.camera.scaled(small.shape[1], small.shape[0]), self.color))
            self._log(f"{layout.latest_keyframe(self.name)}/depth",
                      rr.EncodedDepthImage(png, media_type="image/png", meter=1000.0, colormap="turbo"))
            self._depth_budget.logged(event.frame_index)

    def _graph_edge(self, event: GraphEdge) -> None:
        if event.kind != EdgeKind.LOOP:
            return
        self._loops.append(event)
        self._loops_budget.dirty = True
        verdict = "accepted" if event.accepted else "rejected"
        self._text(f"{event.detection} loop closure KF{event.from_keyframe} -> KF{event.to_keyframe} {verdict} "
                   f"({event.reason}; score {event.score:.3g}, {event.inliers} inliers)",
                   rr.TextLogLevel.INFO if event.accepted else rr.TextLogLevel.DEBUG)

    def _graph_optimized(self, event: GraphOptimized) -> None:
        for keyframe_id, pose in zip(np.asarray(event.keyframe_ids).tolist(), event.poses):
            self._keyframes[keyframe_id] = pose[:3, 3].copy()
        self._keyframes_budget.dirty = True
        self._loops_budget.dirty |= bool(self._loops)  # their ends move with the keyframes
        self._log(layout.metric(self.name, "graph_error"), rr.Scalars(float(event.error_after)))

    def _map_updated(self, event: MapUpdated) -> None:
        self._map.update(event.points, event.colors, event.replace)
        self._map_budget.dirty = True

    # --- growing snapshots --------------------------------------------------------------

    def _log_due_snapshots(self, frame_index: int, final: bool = False) -> None:
        """Re-log the keyframes, loop closures and map when their budget allows (always at the end)."""
        snapshots = ((self._keyframes_budget, len(self._keyframes) * KEYFRAME_BYTES, self._log_keyframes),
                     (self._loops_budget, len(self._loops) * LOOP_CLOSURE_BYTES, self._log_loop_closures),
                     (self._map_budget, self._map.size_estimate * MAP_POINT_BYTES, self._log_map))
        for budget, size, log in snapshots:
            if budget.dirty and (final or budget.due(frame_index, size)):
                log()
                budget.logged(frame_index)

    def _log_keyframes(self) -> None:
        ids = sorted(self._keyframes)
        self._log(layout.keyframes(self.name),
                  rr.Points3D([self._keyframes[i] for i in ids], colors=[self.color],
                              radii=rr.Radius.ui_points(2.5), labels=[f"KF{i}" for i in ids], show_labels=False))

    def _log_loop_closures(self) -> None:
        """Accepted closures as thick green segments; rejected ones, often many, apart in thin red."""
        for accepted, path, color, radius in (
                (True, layout.loop_closures(self.name), layout.ACCEPTED_COLOR, 2.0),
                (False, layout.rejected_loop_closures(self.name), layout.REJECTED_COLOR, 0.5)):
            segments = [[self._keyframes[loop.from_keyframe], self._keyframes[loop.to_keyframe]]
                        for loop in self._loops if loop.accepted == accepted
                        and loop.from_keyframe in self._keyframes and loop.to_keyframe in self._keyframes]
            if segments:
                self._log(path, rr.LineStrips3D(segments, colors=[color], radii=rr.Radius.ui_points(radius)))

    def _log_map(self) -> None:
        self._log(layout.map_cloud(self.name),
                  rr.Points3D(self._map.points.astype(np.float32), colors=self._map.colors,
                              radii=rr.Radius.ui_points(1.5)))

    # --- end of run ---------------------------------------------------------------------

    def _trajectory_final(self, event: TrajectoryFinal) -> None:
        """Final snapshots, then the final trajectory and raw odometry as static strips."""
        self._log_due_snapshots(self.frame_indices[-1] if self.frame_indices else 0, final=True)
        segments = self._tracked_segments(event.frame_indices)
        poses = np.asarray(event.poses).reshape(-1, 4, 4)
        self._log(layout.trajectory(self.name), rr.LineStrips3D(
            [poses[segment, :3, 3] for segment in segments], colors=[self.color],
            radii=rr.Radius.ui_points(3.0)), static=True)
        if event.odometry_poses is not None and len(event.odometry_poses):
            odometry = np.asarray(event.odometry_poses).reshape(-1, 4, 4)
            faded = tuple(int(0.45 * c + 0.55 * 90) for c in self.color)
            self._log(layout.odometry(self.name), rr.LineStrips3D(
                [odometry[segment, :3, 3] for segment in segments], colors=[faded],
                radii=rr.Radius.ui_points(1.0)), static=True)

    def _tracked_segments(self, posed_frames: np.ndarray) -> list[np.ndarray]:
        """Index runs of consecutively processed frames with a pose: no line bridges a loss."""
        processed = np.searchsorted(self.frame_indices, posed_frames)
        breaks = np.flatnonzero(np.diff(processed) > 1) + 1
        return np.split(np.arange(len(posed_frames)), breaks)
