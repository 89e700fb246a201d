"""The recording of `viewslam diff --out`: two runs' trajectories and errors, and their difference.

Run A's entities live under ``A/<run>``, run B's under ``B/<run>`` (``world/A/rtabmap``,
``metrics/B/rtabmap/ate``), the difference B - A under ``metrics/difference/<run>``;
every series is on the sequence's ``frame`` and ``time`` timelines, so scrubbing to a frame
shows both errors and how far apart they are. The file opens laid out (see
:func:`diff_blueprint`) and is written under a temporary name, renamed into place when complete.
"""

from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from .. import palette
from ..atomic import StagedFiles
from ..comparison.compare import Comparison, RunComparison
from ..comparison.reports import RecordedRun
from ..errors import InputError
from . import layout
from .blueprint import LOST_BAND, hidden_legend, log_columns, lost_band_overrides, overview_eye
from .fit import LEFT_SHARE, RIGHT_SHARE
from .frame_columns import send_frame_columns
from .recorder import log_world, lost_colour, transform
from .rrd_file import RecordingFile
from .timelines import gap_starts, log_lost_band, send_log_messages

SIDE_COLORS = {"A": (255, 140, 0), "B": (40, 150, 255)}
DIFFERENCE_COLOR = (200, 80, 220)
POSE_STATES = {"pose": palette.STATUS["ok"].rgb, "no pose": palette.LOST.rgb}


def side_label(side: str, run: str) -> str:
    return f"{side}/{run}"


def difference_label(run: RunComparison) -> str:
    return f"difference/{run.b.name}"


def diff_blueprint(comparison: Comparison) -> rrb.Blueprint:
    """3D view of groundtruth and both runs left; both errors, their difference and the losses right."""
    groundtruth = comparison.sequence.groundtruth
    # No map here: the eye looks at the path itself rather than ahead of it.
    eye = overview_eye(groundtruth.positions) if groundtruth is not None and len(groundtruth) else None
    labels = [
        side_label(side, run.a.name if side == "A" else run.b.name) for run in comparison.runs for side in SIDE_COLORS
    ]  # A's, then B's, of each compared run
    bands = [f"/{layout.metric(label, LOST_BAND)}" for label in labels]
    overrides = lost_band_overrides(bands)
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="world", name="groundtruth grey, A orange, B blue", eye_controls=eye),
            rrb.Vertical(
                rrb.TimeSeriesView(
                    name="ATE per frame [m] · A orange, B blue · bar: no pose",
                    contents=[f"/{layout.metric(label, 'ate')}" for label in labels] + bands,
                    plot_legend=hidden_legend(),
                    overrides=overrides,
                ),
                rrb.StateTimelineView(
                    name="frames with a pose, A and B",
                    contents=[f"/{layout.metric(label, 'pose')}" for label in labels],
                ),
                rrb.TimeSeriesView(
                    name="ATE difference B - A [m] · purple · bar: no pose",
                    contents=[f"/{layout.metric(difference_label(run), 'ate')}" for run in comparison.runs] + bands,
                    plot_legend=hidden_legend(),
                    overrides=overrides,
                ),
                rrb.TextLogView(origin="log", name="losses and their causes", columns=log_columns()),
                row_shares=[2, 1.4, 2, 1.2],
            ),
            column_shares=[LEFT_SHARE, RIGHT_SHARE],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="frame", play_state="following"),
    )


def write_diff_recording(comparison: Comparison, out: Path) -> None:
    """The recording at ``out``, through the file sink guard of every ``.rrd`` (a full disk is one
    line naming ``out``, and whatever was at ``out`` before stays)."""
    with StagedFiles() as staged:
        recording = RecordingFile(staged.path(out), out, diff_blueprint(comparison), application="viewslam-diff")
        try:
            log_world(recording.stream, comparison.sequence.groundtruth)
            for run in comparison.runs:
                _log_run(recording.stream, run)
        finally:
            recording.close()
        if recording.error is not None:
            raise InputError(f"{out}: recording not written: {recording.error}")
        staged.commit()


def _log_run(stream: rr.RecordingStream, run: RunComparison) -> None:
    frames, stamps = run.frame_indices, run.timestamps
    for side, recorded, errors, alignment, tracked in (
        ("A", run.a, run.ate_a, run.alignment_a, run.tracked_a),
        ("B", run.b, run.ate_b, run.alignment_b, run.tracked_b),
    ):
        label, color = side_label(side, recorded.name), SIDE_COLORS[side]
        if alignment is not None:
            stream.log(layout.world(label), transform(alignment), static=True)
        if len(recorded.trajectory):
            stream.log(
                layout.trajectory(label),
                rr.LineStrips3D(_tracked_segments(recorded), colors=[color], radii=rr.Radius.ui_points(2.5)),
                static=True,
            )
        _log_series(stream, layout.metric(label, "ate"), frames, stamps, errors, color, f"{side}: {recorded.name}")
        _log_pose_states(stream, layout.metric(label, "pose"), frames, stamps, tracked)
        stream.log(
            layout.metric(label, LOST_BAND),
            rr.SeriesLines(colors=[lost_colour(palette.Colour(color, side))], names=[f"{side}: no pose"]),
            static=True,
        )
        log_lost_band(stream, layout.metric(label, LOST_BAND), frames, stamps, ~np.asarray(tracked, dtype=bool))
        losses = recorded.block["tracking_lost"]
        send_log_messages(
            stream,
            layout.text_log(label),
            np.array([loss["frame"] for loss in losses], dtype=np.int64),
            np.array([loss["timestamp"] for loss in losses], dtype=np.float64),
            [f"{side}: {loss.get('text') or loss['reason']}" for loss in losses],
            rr.TextLogLevel.WARN,
        )
    _log_series(
        stream,
        layout.metric(difference_label(run), "ate"),
        frames,
        stamps,
        run.ate_difference,
        DIFFERENCE_COLOR,
        "B - A",
    )


def _tracked_segments(recorded: RecordedRun) -> list[np.ndarray]:
    """The trajectory's positions split at the report's lost intervals: no line bridges a loss."""
    trajectory = recorded.trajectory
    coverage = recorded.block["coverage"] or {}
    starts = [start for start, _ in coverage.get("lost_intervals", [])]
    breaks = np.unique(np.searchsorted(trajectory.timestamps, starts, side="right"))
    return np.split(trajectory.positions, breaks[(breaks > 0) & (breaks < len(trajectory))])


def _log_pose_states(
    stream: rr.RecordingStream, path: str, frames: np.ndarray, stamps: np.ndarray, tracked: np.ndarray
) -> None:
    """ "pose" / "no pose" from the first frame on, a row wherever that changes."""
    stream.log(
        path,
        rr.StateConfiguration(values=list(POSE_STATES), labels=list(POSE_STATES), colors=list(POSE_STATES.values())),
        static=True,
    )
    changes = np.flatnonzero(np.diff(tracked.astype(np.int8), prepend=np.int8(-1)) != 0)
    send_frame_columns(
        stream,
        path,
        frames[changes],
        stamps[changes],
        rr.StateChange.columns(state=["pose" if tracked[k] else "no pose" for k in changes]),
    )


def _log_series(
    stream: rr.RecordingStream, path: str, frames: np.ndarray, stamps: np.ndarray, values: np.ndarray, color, name: str
) -> None:
    """The finite values as a line, broken where values are missing."""
    stream.log(path, rr.SeriesLines(colors=[color], names=[name], widths=[2.0]), static=True)
    present = np.isfinite(values)
    send_frame_columns(stream, path, frames[present], stamps[present], rr.Scalars.columns(scalars=values[present]))
    breaks = gap_starts(present)
    send_frame_columns(
        stream, path, frames[breaks], stamps[breaks], rr.Clear.columns(is_recursive=[False] * len(breaks))
    )
