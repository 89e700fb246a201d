"""The causes of a run's losses, written into its recording once the run has ended.

A cause needs the frames after the loss, so it is logged afterwards at the loss's frame:
a warning line in ``log/<run>`` ("rtabmap lost at 8.3 s: too few features (41
keypoints, minimum 100)") and the state series ``metrics/<run>/cause``, which holds the
cause from the loss until the run has a pose again ("tracking").
"""

import contextlib

import numpy as np
import rerun as rr

from .. import palette
from ..diagnosis import Cause, FrameSignals
from . import layout
from .frame_columns import send_frame_columns
from .timelines import send_log_messages

TRACKING = "tracking"
# The longest the run waits for its logged lines to reach the sinks before the causes follow:
# a sink that stalled (a full disk, a viewer that stopped reading) never gets there, and
# closing the recording finds out which and says so.
FLUSH_WAIT_S = 10.0
CAUSE_COLORS = {TRACKING: palette.STATUS["ok"].rgb, **{cause.value: palette.CAUSES[cause.value].rgb for cause in Cause}}


def cause_path(name: str) -> str:
    return layout.metric(name, "cause")


def log_loss_causes(stream: rr.RecordingStream, name: str, losses: list[dict], signals: FrameSignals) -> None:
    """Log each diagnosed loss of run ``name`` (entries with ``cause`` and ``text``) at its frame.

    This is the loss's one log line: the diagnosed cause, then the reason the pipeline gave.
    """
    diagnosed = [loss for loss in losses if "cause" in loss]
    if not diagnosed:
        return
    # The run's own lines at a loss frame (batched) come first, the cause after them. A sink that
    # failed or stalled does not stop the causes: closing the recording reports the sink.
    with contextlib.suppress(RuntimeError):
        stream.flush(timeout_sec=FLUSH_WAIT_S)
    stream.log(
        cause_path(name),
        rr.StateConfiguration(values=list(CAUSE_COLORS), labels=list(CAUSE_COLORS), colors=list(CAUSE_COLORS.values())),
        static=True,
    )
    frames = np.array([loss["frame"] for loss in diagnosed], dtype=np.int64)
    stamps = np.array([loss["timestamp"] for loss in diagnosed], dtype=np.float64)
    send_log_messages(
        stream,
        layout.text_log(name),
        frames,
        stamps,
        [f"{loss['text']}; the pipeline: {loss['reason']}" for loss in diagnosed],
        rr.TextLogLevel.WARN,
    )
    changes = [(frame, stamp, loss["cause"]) for frame, stamp, loss in zip(frames, stamps, diagnosed)]
    changes += _recoveries(frames, signals)
    changes.sort(key=lambda change: change[0])
    send_frame_columns(
        stream,
        cause_path(name),
        np.array([c[0] for c in changes], dtype=np.int64),
        np.array([c[1] for c in changes], dtype=np.float64),
        rr.StateChange.columns(state=[c[2] for c in changes]),
    )


def _recoveries(loss_frames: np.ndarray, signals: FrameSignals) -> list[tuple[int, float, str]]:
    """(frame, stamp, "tracking") at the first frame with a pose after each loss."""
    recoveries = {}
    for frame in loss_frames:
        later = np.flatnonzero(signals.tracked & (signals.frame_indices > frame))
        if len(later):
            row = later[0]
            recoveries[int(signals.frame_indices[row])] = float(signals.timestamps[row])
    return [(frame, stamp, TRACKING) for frame, stamp in recoveries.items() if frame not in set(loss_frames.tolist())]
