"""Evaluation results written back onto the ``frame`` timeline once a run has ended.

ATE needs the final alignment and RPE needs poses a second ahead, so neither exists while
the pipeline runs; logging them afterwards at each frame's index lets a user scrub to the
frame where the error grew.
"""

import numpy as np
import rerun as rr

from ..evaluation import Evaluation
from . import layout
from .blueprint import LOST_BAND
from .fit import log_rows
from .frame_columns import send_frame_columns
from .recorder import transform


def frames_at(stamps: np.ndarray, frame_timestamps: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """Positions in ``frame_timestamps`` (sorted) of ``stamps``, -1 where no frame has that stamp."""
    stamps = np.asarray(stamps, dtype=np.float64)
    if len(frame_timestamps) == 0:
        return np.full(len(stamps), -1)
    position = np.clip(np.searchsorted(frame_timestamps, stamps - tolerance), 0, len(frame_timestamps) - 1)
    return np.where(np.abs(frame_timestamps[position] - stamps) <= tolerance, position, -1)


def coverage_so_far(frame_timestamps: np.ndarray, lost_intervals: list[tuple[float, float]]) -> np.ndarray:
    """At each frame time after the first: share of the time since the first frame with a pose."""
    start = frame_timestamps[0]
    lost = np.zeros(len(frame_timestamps))
    for lost_start, lost_end in lost_intervals:
        lost += np.clip(np.minimum(frame_timestamps, lost_end) - lost_start, 0.0, None)
    elapsed = frame_timestamps - start
    return 1.0 - np.divide(lost, elapsed, out=np.zeros_like(lost), where=elapsed > 0)


def gap_starts(present: np.ndarray) -> np.ndarray:
    """Positions of frames without a value that follow one with a value: where a plot must break."""
    present = np.asarray(present, dtype=bool)
    return np.flatnonzero(present[:-1] & ~present[1:]) + 1


def lost_frames(frame_timestamps: np.ndarray, lost_intervals: list[tuple[float, float]]) -> np.ndarray:
    """Which frames lie in a lost interval, its ends (the last pose before, the first after) included."""
    lost = np.zeros(len(frame_timestamps), dtype=bool)
    for start, end in lost_intervals:
        lost |= (frame_timestamps >= start - 1e-6) & (frame_timestamps <= end + 1e-6)
    return lost


def _send_series(
    stream: rr.RecordingStream, path: str, frame_indices: np.ndarray, frame_timestamps: np.ndarray, values: np.ndarray
) -> None:
    send_frame_columns(
        stream, path, frame_indices, frame_timestamps, rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64))
    )


def log_evaluation(
    stream: rr.RecordingStream,
    name: str,
    evaluation: Evaluation,
    frame_indices: np.ndarray,
    frame_timestamps: np.ndarray,
) -> None:
    """Align the pipeline's map frame to groundtruth and log ATE (global and segment-aligned), RPE
    and coverage per frame.

    ``frame_indices``/``frame_timestamps`` are the frames the pipeline processed, in order.
    """
    frame_indices = np.asarray(frame_indices, dtype=np.int64)
    frame_timestamps = np.asarray(frame_timestamps, dtype=np.float64)
    if evaluation.alignment is not None:
        stream.log(layout.world(name), transform(evaluation.alignment), static=True)
    for series, errors in (
        ("ate", evaluation.ate),
        ("ate_segments", evaluation.segment_ate),
        ("rpe_trans", evaluation.rpe_trans),
        ("rpe_rot", evaluation.rpe_rot),
    ):
        if errors is None:
            continue
        position = frames_at(errors.timestamps, frame_timestamps)
        kept = position >= 0
        path = layout.metric(name, series)
        _send_series(stream, path, frame_indices[position[kept]], frame_timestamps[position[kept]], errors.errors[kept])
        present = np.zeros(len(frame_indices), dtype=bool)
        present[position[kept]] = True
        breaks = gap_starts(present)
        send_frame_columns(
            stream,
            path,
            frame_indices[breaks],
            frame_timestamps[breaks],
            rr.Clear.columns(is_recursive=[False] * len(breaks)),
        )
    log_lost_band(
        stream,
        layout.metric(name, LOST_BAND),
        frame_indices,
        frame_timestamps,
        lost_frames(frame_timestamps, evaluation.coverage.lost_intervals),
    )
    if len(frame_timestamps) > 1:
        coverage = coverage_so_far(frame_timestamps, evaluation.coverage.lost_intervals)
        _send_series(stream, layout.metric(name, "coverage"), frame_indices[1:], frame_timestamps[1:], coverage[1:])


def log_lost_band(
    stream: rr.RecordingStream, path: str, frame_indices: np.ndarray, frame_timestamps: np.ndarray, lost: np.ndarray
) -> None:
    """A series at zero across the ``lost`` frames, broken between lost spans: on an error plot
    it is a bar under the stretch where the run had no pose, up to where the playhead runs."""
    _send_series(stream, path, frame_indices[lost], frame_timestamps[lost], np.zeros(int(lost.sum())))
    breaks = gap_starts(lost)
    send_frame_columns(
        stream,
        path,
        frame_indices[breaks],
        frame_timestamps[breaks],
        rr.Clear.columns(is_recursive=[False] * len(breaks)),
    )


def send_log_messages(
    stream: rr.RecordingStream,
    path: str,
    frame_indices: np.ndarray,
    frame_timestamps: np.ndarray,
    texts: list[str],
    level: rr.TextLogLevel,
) -> None:
    """Text log messages at their frames, each in the rows the log view shows whole (:func:`.fit.log_rows`)."""
    rows = [
        (frame, stamp, row)
        for frame, stamp, text in zip(frame_indices, frame_timestamps, texts)
        for row in log_rows(text)
    ]
    send_frame_columns(
        stream,
        path,
        np.array([row[0] for row in rows], dtype=np.int64),
        np.array([row[1] for row in rows], dtype=np.float64),
        rr.TextLog.columns(text=[row[2] for row in rows], level=[level] * len(rows)),
    )
