"""What a recording of trajectory files alone holds (``viewslam record --groundtruth FILE --estimate NAME=FILE ...``).

With no sequence there are no images and no camera: the recording shows what the files can
show, scored as ``viewslam evaluate`` scores them (:mod:`viewer_slam.runs.trajectory_files`):

- ``world/groundtruth``, and under ``world/<run>`` (whose transform is the run's ATE
  alignment) the run's ``trajectory`` broken at its lost intervals, its ``poses`` coloured
  by their ATE error, ``correspondences`` from each pose to its groundtruth pose, a
  ``camera`` (axes) that moves along the timelines, and while lost a label at the last pose;
- ``metrics/<run>/...``: the evaluation series of a pipeline's recording (global and
  segment-aligned ATE, RPE, coverage so far, the lost band) and the tracking state;
- ``log/<run>``: a line at each loss (when the run stopped, for one that quit) and recovery;
- for an RTAB-Map database, its graph: loop closures and proximity links as green segments
  between its nodes (``world/<run>/loop_closures``), the hypotheses it rejected in red, and
  a log line at each closure and at each new map;
- ``summary``: the scores and lost intervals of every run as Markdown.

The ``frame`` timeline counts the groundtruth's poses (each instant at the nearest one),
``time`` is the files' own clock. A run's series are logged at its poses and, inside its
lost intervals, once per pose interval of the run, so the plots break where it had no
pose and the lost band runs through that time. The files are scored, and the report and
trajectories written beside the recording, by :mod:`viewer_slam.record.files`.
"""

import numpy as np
import rerun as rr

from .. import palette
from ..evaluation.coverage import MIN_LOST_GAP_S, median_period
from ..geometry.trajectory import Trajectory
from ..runs.files_summary import summary_markdown
from ..runs.trajectory_files import ScoredFile, ScoredFiles
from . import layout
from .frame_columns import send_frame_columns
from .recorder import TRAJECTORY_WIDTH, log_run_styles, log_world, set_frame_time
from .sizes import extent, scene_sizes
from .timelines import log_evaluation

POSE_RADIUS = 3.0  # ui points
CORRESPONDENCE_WIDTH = 0.25  # ui points: a pose a frame makes a dense fan
CORRESPONDENCE_FADE = 0.8  # share of the background grey mixed into the run's colour


def log_files(stream: rr.RecordingStream, scored: ScoredFiles, error_top: float) -> None:
    """Everything of the module docstring into ``stream``; pose colours saturate at ``error_top`` metres."""
    groundtruth = scored.groundtruth
    log_world(stream, groundtruth)
    stream.log(layout.SUMMARY, rr.TextDocument(summary_markdown(scored), media_type=rr.MediaType.MARKDOWN), static=True)
    axis_length = scene_sizes(extent(groundtruth.positions)).frustum_depth
    for position, run in enumerate(scored.runs):
        colour = palette.run_colour(run.name, position)
        log_run_styles(stream, run.name, colour)
        frames, stamps = run_clock(groundtruth.timestamps, run)
        log_evaluation(stream, run.name, run.evaluation, frames, stamps)
        log_shape(stream, run, colour, groundtruth, error_top)
        log_motion(stream, run, colour, groundtruth, axis_length)
        if run.database is not None:
            log_graph(stream, run, groundtruth)


def nearest_frames(groundtruth_stamps: np.ndarray, stamps: np.ndarray) -> np.ndarray:
    """The index of the groundtruth pose nearest in time to each of ``stamps``: its place on the frame timeline."""
    after = np.clip(np.searchsorted(groundtruth_stamps, stamps), 0, len(groundtruth_stamps) - 1)
    before = np.maximum(after - 1, 0)
    closer_before = np.abs(stamps - groundtruth_stamps[before]) <= np.abs(groundtruth_stamps[after] - stamps)
    return np.where(closer_before, before, after).astype(np.int64)


def run_clock(groundtruth_stamps: np.ndarray, run: ScoredFile) -> tuple[np.ndarray, np.ndarray]:
    """Frames and stamps, in time order, at which the run's series are logged: each of its poses and,
    inside each lost interval, one instant per pose interval of the run up to the interval's end."""
    stamps = run.trajectory.timestamps
    period = median_period(stamps) or MIN_LOST_GAP_S
    lost = [
        np.append(np.arange(start + period, end - period / 2, period), end)
        for start, end in run.evaluation.coverage.lost_intervals
    ]
    lost_stamps = np.concatenate(lost) if lost else np.zeros(0)
    instants = np.sort(np.concatenate([stamps, lost_stamps[~np.isin(lost_stamps, stamps)]]), kind="stable")
    return nearest_frames(groundtruth_stamps, instants), instants


def log_shape(
    stream: rr.RecordingStream, run: ScoredFile, colour: palette.Colour, groundtruth: Trajectory, error_top: float
) -> None:
    """The static geometry of a run in its own frame (``world/<run>`` carries the alignment): the
    trajectory broken where it was lost, the poses coloured by error and the correspondence lines."""
    positions = run.trajectory.positions
    starts = [start for start, _ in run.evaluation.coverage.lost_intervals]
    breaks = np.flatnonzero(np.isin(run.trajectory.timestamps[:-1], starts)) + 1
    segments = [segment for segment in np.split(positions, breaks) if len(segment) > 1]
    if segments:
        stream.log(
            layout.trajectory(run.name),
            rr.LineStrips3D(segments, colors=[colour.rgb], radii=rr.Radius.ui_points(TRAJECTORY_WIDTH)),
            static=True,
        )
    stream.log(
        layout.poses(run.name),
        rr.Points3D(
            positions,
            colors=palette.error_colours(run.pose_errors(), error_top),
            radii=rr.Radius.ui_points(POSE_RADIUS),
        ),
        static=True,
    )
    gt_index, est_index = run.evaluation.pairs
    to_estimate = np.linalg.inv(run.alignment)
    reference = groundtruth.positions[gt_index] @ to_estimate[:3, :3].T + to_estimate[:3, 3]
    stream.log(
        layout.correspondences(run.name),
        rr.LineStrips3D(
            np.stack([positions[est_index], reference], axis=1),
            colors=[palette.faded(colour, CORRESPONDENCE_FADE, towards=40)],
            radii=rr.Radius.ui_points(CORRESPONDENCE_WIDTH),
        ),
        static=True,
    )


def log_graph(stream: rr.RecordingStream, run: ScoredFile, groundtruth: Trajectory) -> None:
    """An RTAB-Map database's loop closures, proximity links and rejected hypotheses between its
    nodes (its poses, in order), and a log line at each and at each new map."""
    assert run.database is not None
    nodes = run.database.nodes
    position = {node.id: run.trajectory.positions[index] for index, node in enumerate(nodes)}
    frames = nearest_frames(groundtruth.timestamps, np.array([node.stamp for node in nodes]))
    closures: dict[bool, list[np.ndarray]] = {True: [], False: []}
    for node, frame in zip(nodes, frames):
        lines = [f"{run.name}: new map {node.map_id}"] if node.stamp in run.trajectory.resumptions else []
        for edge in run.edges[node.id]:
            if edge.detection in ("odometry", "user"):
                continue
            closures[edge.accepted].append(np.stack([position[edge.from_id], position[edge.to_id]]))
            verdict = "loop closure" if edge.accepted else "rejected hypothesis"
            lines.append(
                f"{run.name}: {verdict} {edge.from_id} -> {edge.to_id} by {edge.detection}"
                + (f" (hypothesis {edge.score:.2f}, {edge.inliers} inliers)" if edge.detection == "appearance" else "")
            )
        if lines:
            set_frame_time(stream, int(frame), node.stamp)
            for line in lines:
                stream.log(layout.text_log(run.name), rr.TextLog(line, level=rr.TextLogLevel.INFO))
    for accepted, path, colour in (
        (True, layout.loop_closures(run.name), palette.ACCEPTED),
        (False, layout.rejected_loop_closures(run.name), palette.REJECTED),
    ):
        if closures[accepted]:
            stream.log(
                path,
                rr.LineStrips3D(closures[accepted], colors=[colour.rgb], radii=rr.Radius.ui_points(TRAJECTORY_WIDTH)),
                static=True,
            )


def log_motion(
    stream: rr.RecordingStream, run: ScoredFile, colour: palette.Colour, groundtruth: Trajectory, axis_length: float
) -> None:
    """What changes along the timelines: the camera axes at each pose, and at each loss and recovery
    the tracking state, a log line and the label at the last pose."""
    name, trajectory = run.name, run.trajectory
    frames = nearest_frames(groundtruth.timestamps, trajectory.timestamps)
    stream.log(layout.camera(name), rr.TransformAxes3D(axis_length), static=True)
    send_frame_columns(
        stream,
        layout.camera(name),
        frames,
        trajectory.timestamps,
        rr.Transform3D.columns(translation=trajectory.positions, mat3x3=trajectory.poses[:, :3, :3]),
    )
    set_frame_time(stream, frames[0], trajectory.timestamps[0])
    stream.log(layout.metric(name, "tracking_state"), rr.StateChange(state=["ok"]))
    lost_intervals = run.evaluation.coverage.lost_intervals
    for loss, (start, end) in zip(run.losses(groundtruth), lost_intervals):
        set_frame_time(stream, loss["frame"], loss["timestamp"])
        stream.log(layout.metric(name, "tracking_state"), rr.StateChange(state=["lost"]))
        stream.log(layout.text_log(name), rr.TextLog(f"{loss['text']} ({loss['reason']})", level=rr.TextLogLevel.WARN))
        last = trajectory.positions[max(int(np.searchsorted(trajectory.timestamps, start, side="right")) - 1, 0)]
        stream.log(
            layout.lost_label(name),
            rr.Points3D(
                [last],
                colors=[colour.rgb],
                radii=rr.Radius.ui_points(POSE_RADIUS + 1.0),
                labels=[f"{name} lost"],
                show_labels=True,
            ),
        )
        if start == run.evaluation.coverage.stopped_at:
            continue
        set_frame_time(stream, int(nearest_frames(groundtruth.timestamps, np.array([end]))[0]), end)
        stream.log(layout.metric(name, "tracking_state"), rr.StateChange(state=["ok"]))
        stream.log(
            layout.text_log(name),
            rr.TextLog(f"{name}: poses again after {end - start:.1f} s", level=rr.TextLogLevel.INFO),
        )
        stream.log(layout.lost_label(name), rr.Clear(recursive=False))
