"""Rows stamped on the ``frame`` and ``time`` timelines, sent to Rerun as columns.

At every frame a run logs a score of numbers (counts, milliseconds per stage, the graph's
error), the camera's pose and the lines of its matches. Logged one row at a time, each row
costs Rerun's Python layer far more than what it carries (building the archetype,
converting it, handing one row over), and that time is taken from the pipelines on a
machine whose cores they keep busy. :class:`HeldRows` holds such rows instead and sends
them once ``FLUSH_FRAMES`` frames are held, each entity's as one column per kind of row:
the recording gets the same rows (entities, values, both timelines' values), each entity's
in the order they came, for a fraction of the cost. A viewer watching live sees them at
most that many frames late; Rerun's batcher holds rows for up to a second anyway.
"""

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import rerun as rr

# Frames whose rows are held before they are sent: about a second of a 30 Hz sensor.
FLUSH_FRAMES = 30


def send_frame_columns(
    stream: rr.RecordingStream, path: str, frame_indices: np.ndarray, frame_timestamps: np.ndarray, columns
) -> None:
    """Send rows stamped on both timelines; nothing at all when there are no rows.

    Every column send of the recording goes through here: the Rerun viewer (0.41) panics
    on a recording holding zero-row chunks (an empty time range), so none may be written.
    """
    if len(frame_indices) == 0:
        return
    stream.send_columns(
        path,
        indexes=[rr.TimeColumn("frame", sequence=frame_indices), rr.TimeColumn("time", timestamp=frame_timestamps)],
        columns=columns,
    )


def logged_nanoseconds(timestamps: list[float] | np.ndarray) -> np.ndarray:
    """Timestamps in seconds as the nanoseconds ``set_time(timestamp=...)`` makes of them (rounded,
    where a column of seconds would be truncated): a row sent here has the time it would have had
    if logged."""
    seconds = np.asarray(timestamps, dtype=np.float64)
    return np.round(1e9 * seconds).astype(np.int64).astype("datetime64[ns]")


def _scalars(values: list[float]) -> Any:
    return rr.Scalars.columns(scalars=np.asarray(values, dtype=np.float64))


def _transforms(poses: list[np.ndarray]) -> Any:
    stacked = np.asarray(poses, dtype=np.float64).reshape(-1, 4, 4)
    return rr.Transform3D.columns(translation=stacked[:, :3, 3], mat3x3=stacked[:, :3, :3])


def _segments(rows: list[tuple[np.ndarray, float]]) -> Any:
    """Rows of 2D segments ((n, 2, 2) each, n > 0) with one radius each."""
    strips = rr.LineStrips2D.columns(strips=np.concatenate([segments for segments, _ in rows]))
    radii = rr.LineStrips2D.columns(radii=np.asarray([radius for _, radius in rows], dtype=np.float32))
    return [*strips.partition([len(segments) for segments, _ in rows]), *radii]


def _clears(recursive: list[bool]) -> Any:
    return rr.Clear.columns(is_recursive=recursive)


@dataclass(eq=False)  # runs are told apart by identity
class _Run:
    """Rows of one entity of one kind: ``columns`` turns their values into Rerun columns."""

    columns: Callable[[list[Any]], Any]
    frames: list[int] = field(default_factory=list)
    timestamps: list[float] = field(default_factory=list)
    values: list[Any] = field(default_factory=list)

    def at_end(self, frame: int, timestamp: float) -> bool:
        """Whether the run's last row is at this frame and time."""
        return self.frames[-1] == frame and self.timestamps[-1] == timestamp


class HeldRows:
    """Rows held per entity, sent as columns every ``flush_frames`` frames and at :meth:`flush`.

    Each method says which row it stands for, at frame ``frame`` and time ``timestamp``. The
    caller says when a frame begins (:meth:`next_frame`) and calls :meth:`flush` when its
    run ends, however it ends: rows still held are otherwise lost.
    """

    def __init__(self, stream: rr.RecordingStream, flush_frames: int = FLUSH_FRAMES):
        self._stream = stream
        self._flush_frames = flush_frames
        self._frames = 0
        self._runs: dict[str, list[_Run]] = {}
        self._last: dict[str, _Run] = {}  # the run holding each entity's latest row

    def scalar(self, path: str, frame: int, timestamp: float, value: float) -> None:
        """``rr.Scalars(value)``."""
        self._add(path, _scalars, frame, timestamp, float(value))

    def transform(self, path: str, frame: int, timestamp: float, pose: np.ndarray) -> None:
        """``rr.Transform3D(translation=..., mat3x3=...)`` of the 4x4 ``pose``."""
        self._add(path, _transforms, frame, timestamp, pose)

    def segments(self, path: str, frame: int, timestamp: float, segments: np.ndarray, radius: float) -> None:
        """``rr.LineStrips2D(segments, radii=radius)`` of (n, 2, 2) float32 ``segments``, n > 0."""
        assert len(segments), "an empty batch is a Clear"
        self._add(path, _segments, frame, timestamp, (segments, float(radius)))

    def clear(self, path: str, frame: int, timestamp: float, recursive: bool) -> None:
        """``rr.Clear(recursive=recursive)``."""
        self._add(path, _clears, frame, timestamp, recursive)

    def next_frame(self) -> None:
        """A frame begins: send what is held once ``flush_frames`` frames are."""
        if self._frames >= self._flush_frames:
            self.flush()
        self._frames += 1

    def flush(self) -> None:
        """Send every entity's held rows, a column per run of rows of one kind, in order."""
        for path, runs in self._runs.items():
            for run in runs:
                send_frame_columns(
                    self._stream,
                    path,
                    np.asarray(run.frames, dtype=np.int64),
                    logged_nanoseconds(run.timestamps),
                    run.columns(run.values),
                )
        self._runs, self._last = {}, {}
        self._frames = 0

    def _add(self, path: str, columns: Callable[[list[Any]], Any], frame: int, timestamp: float, value: Any) -> None:
        """Add the row to its entity's latest run of its kind, unless that run is sent before the
        one holding the entity's row before it at the same time; then to a new run, sent last.

        Only rows at the same time need keep their order (a later time wins whatever the
        order), and those come one after the other, so each entity's rows go in a column or
        two per kind while rows at one time are sent in the order they came.
        """
        runs = self._runs.setdefault(path, [])
        before = self._last.get(path)
        earliest = runs.index(before) if before is not None and before.at_end(frame, timestamp) else 0
        run = next((run for run in reversed(runs[earliest:]) if run.columns is columns), None)
        if run is None:
            run = _Run(columns)
            runs.append(run)
        run.frames.append(int(frame))
        run.timestamps.append(float(timestamp))
        run.values.append(value)
        self._last[path] = run
