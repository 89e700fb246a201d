"""Coverage-aware scores: how much of the groundtruth time a method had a pose for.

ATE and RPE only look at the poses a method produced, so a method that gives up early
can look better than one that keeps going. Coverage measures the time without a pose,
and the penalised ATE charges that time with the error of the pose the method last had.
"""

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..geometry.interpolation import interpolate_poses
from ..geometry.trajectory import Trajectory
from .ate import absolute_errors

MIN_LOST_GAP_S = 0.1
LOST_GAP_PERIODS = 3.0


class Span(NamedTuple):
    """The time window coverage is measured over, on the groundtruth's clock, and the rule that chose it."""

    start: float
    end: float
    rule: str = "given"

    def to_dict(self) -> dict:
        return {"start": self.start, "end": self.end, "rule": self.rule}


FILE_SPAN_RULE = "estimate start to groundtruth end"


def file_span(groundtruth_stamps: np.ndarray, estimate_stamps: np.ndarray) -> Span:
    """The span of a bare groundtruth file: from the later of the two first stamps to the groundtruth's end.

    Motion capture usually runs before the camera, so time before the estimate's first
    pose is no evidence of a loss; time after its last pose is what a method that quits
    leaves out, so the span runs on to the groundtruth's end (docs/metrics.md).
    """
    start, end = float(groundtruth_stamps[0]), float(groundtruth_stamps[-1])
    if len(estimate_stamps) == 0:
        return Span(start, end, "groundtruth")
    return Span(min(max(start, float(estimate_stamps[0])), end), end, FILE_SPAN_RULE)


@dataclass
class Coverage:
    """Share of the evaluated time span with a pose, and the maximal stretches without."""

    ratio: float
    lost_intervals: list[tuple[float, float]]
    span: Span

    def to_dict(self) -> dict:
        return {"ratio": self.ratio, "lost_intervals": [[start, end] for start, end in self.lost_intervals],
                "span": self.span.to_dict()}


def median_period(stamps: np.ndarray) -> float | None:
    """The median time between consecutive stamps, None with fewer than two."""
    return float(np.median(np.diff(stamps))) if len(stamps) > 1 else None


def lost_gap_threshold(stamps: np.ndarray, frame_period: float | None = None) -> float:
    """A stretch without poses longer than this is lost: max(0.1 s, 3 frame periods).

    Three periods tolerate a dropped frame or two; the 0.1 s floor keeps the jitter of
    fast cameras from counting as tracking loss. The period is the sequence's own when the
    caller knows it, else the estimate's median spacing (a bare trajectory file).
    """
    period = frame_period or median_period(stamps)
    return MIN_LOST_GAP_S if period is None else max(MIN_LOST_GAP_S, LOST_GAP_PERIODS * period)


def coverage(span: Span | tuple[float, float], stamps: np.ndarray, frame_period: float | None = None) -> Coverage:
    """Coverage of ``span`` (start, end[, rule]) by pose ``stamps`` (sorted, on the span's clock).

    The span's ends and the stamps inside it form a chain of instants; every gap in that
    chain longer than :func:`lost_gap_threshold` is a lost interval, and the ratio is one
    minus their total length over the span's length.
    """
    span = Span(*span)
    start, end = span.start, span.end
    inside = stamps[(stamps >= start) & (stamps <= end)]
    if len(inside) == 0:
        return Coverage(0.0, [(float(start), float(end))], span)
    instants = np.concatenate([[start], inside, [end]])
    gaps = np.diff(instants)
    lost = np.flatnonzero(gaps > lost_gap_threshold(stamps, frame_period))
    intervals = [(float(instants[k]), float(instants[k + 1])) for k in lost]
    duration = end - start
    ratio = 1.0 - float(gaps[lost].sum() / duration) if duration > 0 else 1.0
    return Coverage(ratio, intervals, span)


def tracked_segments(stamps: np.ndarray, frame_period: float | None = None) -> np.ndarray:
    """The segment number (0, 1, ...) of every pose: a new segment starts after each gap that is lost.

    The same threshold as :func:`coverage`, so the segments are exactly the stretches
    between lost intervals (gaps outside the span split them too).
    """
    if len(stamps) == 0:
        return np.zeros(0, dtype=int)
    breaks = np.diff(stamps) > lost_gap_threshold(stamps, frame_period)
    return np.concatenate([[0], np.cumsum(breaks)])


def held_pose_errors(groundtruth: Trajectory, estimate: Trajectory, pose_alignment: np.ndarray,
                     lost_intervals: list[tuple[float, float]],
                     frame_period: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Stamps and errors of the penalty samples inside the lost intervals.

    Samples lie every frame period (else median estimate period) inside each interval (so lost time weighs as
    much as tracked time); at each, the groundtruth is interpolated and compared with the
    aligned last estimate pose before it (zero-order hold; the first pose before the
    first). ``pose_alignment`` holds the transform ``(N, 4, 4)`` of each estimate pose;
    ``estimate`` stamps are on the groundtruth's clock.
    """
    period = frame_period or median_period(estimate.timestamps) or median_period(groundtruth.timestamps) or MIN_LOST_GAP_S
    samples = [np.arange(start + period, end, period) for start, end in lost_intervals]
    stamps = np.concatenate(samples) if samples else np.zeros(0)
    reference, covered = interpolate_poses(groundtruth, stamps)
    stamps, reference = stamps[covered], reference[covered]
    held = np.maximum(np.searchsorted(estimate.timestamps, stamps, side="right") - 1, 0)
    return stamps, absolute_errors(reference[:, :3, 3], estimate.positions[held], pose_alignment[held])
