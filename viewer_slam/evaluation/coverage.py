"""Coverage-aware scores: how much of the groundtruth time a method had a pose for.

ATE and RPE only look at the poses a method produced, so a method that gives up early
can look better than one that keeps going. Coverage measures the time without a pose,
and the penalised ATE charges that time with the error of the pose the method last had.

Not every gap is a loss: RTAB-Map exports one node a second, keyframe systems a pose only
when the view has changed enough (and cull redundant keyframes later). The gap rule
(docs/metrics.md): a gap is lost when it is longer than max(0.1 s, 3 frame periods, 3 of
the estimate's own pose intervals), the estimate's interval being its median one when it
has a pose per frame, and its 90th-percentile one when it is *sparse* (median interval above
max(0.1 s, 3 frame periods): nodes or keyframes, whose spacing varies with the motion).
A sparse estimate's gap scored against groundtruth is lost only if the groundtruth camera
also moved during it more than 3 times what it typically moves between two of the
estimate's consecutive poses (in translation or rotation, a step counting at least 5 cm /
0.05 rad), so a system that adds no node while the camera rests is not lost. An estimate's own rhythm
counts only from 4 poses on when the frame period is known: two or three poses say
nothing about a rate, and are judged at the frame rate.
"""

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from ..geometry.interpolation import interpolate_poses
from ..geometry.trajectory import Trajectory
from .ate import absolute_errors

MIN_LOST_GAP_S = 0.1
LOST_GAP_PERIODS = 3.0
SPARSE_INTERVAL_PERCENTILE = 90.0
MIN_POSES_FOR_RHYTHM = 4
LOST_GAP_MOTIONS = 3.0  # a sparse estimate's gap is lost when the camera moved this many typical steps
MIN_STEP_M = 0.05
MIN_STEP_RAD = 0.05


class Span(NamedTuple):
    """The time window coverage is measured over, on the groundtruth's clock, and the rule that chose it."""

    start: float
    end: float
    rule: str = "given"

    def to_dict(self) -> dict[str, Any]:
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

    @property
    def stopped_at(self) -> float | None:
        """When the method produced its last pose, if no pose follows it up to the span's end (it
        quit); None when it had a pose to the end."""
        if self.lost_intervals and self.lost_intervals[-1][1] == self.span.end:
            return self.lost_intervals[-1][0]
        return None

    def to_dict(self) -> dict[str, Any]:
        return {
            "ratio": self.ratio,
            "lost_intervals": [[start, end] for start, end in self.lost_intervals],
            "span": self.span.to_dict(),
        }


def median_period(stamps: np.ndarray) -> float | None:
    """The median time between consecutive stamps, None with fewer than two."""
    return float(np.median(np.diff(stamps))) if len(stamps) > 1 else None


def lost_gap_threshold(stamps: np.ndarray, frame_period: float | None = None) -> float:
    """A stretch without poses longer than this is lost: max(0.1 s, 3 frame periods, 3 of the
    estimate's own pose intervals: the median one, or the 90th-percentile one of a sparse estimate).

    Three periods tolerate a dropped frame or two; the 0.1 s floor keeps the jitter of
    fast cameras from counting as tracking loss. The frame period is the sequence's own when
    the caller knows it; the estimate's own spacing keeps a trajectory of one node a second
    (RTAB-Map's export) from being lost between every two nodes, and the percentile a
    keyframe trajectory from being lost wherever the camera moved slowly.
    """
    own = _own_period(stamps, frame_period)
    if own is not None and is_sparse(stamps, frame_period):
        own = float(np.percentile(np.diff(stamps), SPARSE_INTERVAL_PERCENTILE))
    periods = [period for period in (frame_period, own) if period]
    return max([MIN_LOST_GAP_S] + [LOST_GAP_PERIODS * period for period in periods])


def _own_period(stamps: np.ndarray, frame_period: float | None) -> float | None:
    """The estimate's median pose interval where its rhythm counts (module docstring), else None."""
    if frame_period and len(stamps) < MIN_POSES_FOR_RHYTHM:
        return None
    return median_period(stamps)


def is_sparse(stamps: np.ndarray, frame_period: float | None = None) -> bool:
    """Whether the estimate holds nodes or keyframes rather than a pose per frame: its median pose
    interval is longer than max(0.1 s, 3 frame periods) (and its rhythm counts)."""
    own = _own_period(stamps, frame_period)
    return own is not None and own > max(MIN_LOST_GAP_S, LOST_GAP_PERIODS * (frame_period or 0.0))


class _CameraMotion:
    """The groundtruth camera's travelled path and turned angle up to any instant (interpolated)."""

    def __init__(self, groundtruth: Trajectory):
        poses = groundtruth.poses
        steps = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
        relative = np.swapaxes(poses[:-1, :3, :3], 1, 2) @ poses[1:, :3, :3]
        cosine = np.clip((np.trace(relative, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)
        self.stamps = groundtruth.timestamps
        self.path = np.concatenate([[0.0], np.cumsum(steps)])
        self.turn = np.concatenate([[0.0], np.cumsum(np.arccos(cosine))])

    def between(self, starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Metres travelled and radians turned from each start to its end."""
        return (
            np.interp(ends, self.stamps, self.path) - np.interp(starts, self.stamps, self.path),
            np.interp(ends, self.stamps, self.turn) - np.interp(starts, self.stamps, self.turn),
        )


def coverage(
    span: Span | tuple[float, float],
    stamps: np.ndarray,
    frame_period: float | None = None,
    groundtruth: Trajectory | None = None,
    resumptions: np.ndarray | None = None,
) -> Coverage:
    """Coverage of ``span`` (start, end[, rule]) by pose ``stamps`` (sorted, on the span's clock).

    The span's ends and the stamps inside it form a chain of instants; every gap in that
    chain longer than :func:`lost_gap_threshold` is a lost interval (for a sparse estimate
    with ``groundtruth``, only if the camera moved enough during it: the module's rule), as
    is the gap before each of ``resumptions`` (stamps where the estimate itself says it
    resumed after a loss, :class:`~viewer_slam.geometry.trajectory.Trajectory`); the ratio
    is one minus their total length over the span's length.
    """
    span = Span(*span)
    start, end = span.start, span.end
    inside = stamps[(stamps >= start) & (stamps <= end)]
    if len(inside) == 0:
        return Coverage(0.0, [(float(start), float(end))], span)
    instants = np.concatenate([[start], inside, [end]])
    gaps = np.diff(instants)
    lost = np.flatnonzero(gaps > lost_gap_threshold(stamps, frame_period))
    if groundtruth is not None and len(groundtruth) > 1 and len(inside) > 1 and is_sparse(stamps, frame_period):
        lost = lost[_moved_enough(_CameraMotion(groundtruth), inside, instants[lost], instants[lost + 1])]
    if resumptions is not None and len(resumptions):
        lost = np.union1d(lost, np.flatnonzero(np.isin(instants[1:-1], resumptions)))
    intervals = [(float(instants[k]), float(instants[k + 1])) for k in lost]
    duration = end - start
    ratio = 1.0 - float(gaps[lost].sum() / duration) if duration > 0 else 1.0
    return Coverage(ratio, intervals, span)


def _moved_enough(motion: _CameraMotion, stamps: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Which gaps saw the camera move more than LOST_GAP_MOTIONS typical steps between consecutive poses."""
    step_path, step_turn = motion.between(stamps[:-1], stamps[1:])
    typical_path = max(float(np.median(step_path)), MIN_STEP_M)
    typical_turn = max(float(np.median(step_turn)), MIN_STEP_RAD)
    path, turn = motion.between(starts, ends)
    return (path > LOST_GAP_MOTIONS * typical_path) | (turn > LOST_GAP_MOTIONS * typical_turn)


def tracked_segments(
    stamps: np.ndarray, frame_period: float | None = None, resumptions: np.ndarray | None = None
) -> np.ndarray:
    """The segment number (0, 1, ...) of every pose: a new segment starts after each gap that is lost.

    The same threshold and ``resumptions`` as :func:`coverage`, so the segments are exactly
    the stretches between lost intervals (gaps outside the span split them too).
    """
    if len(stamps) == 0:
        return np.zeros(0, dtype=int)
    breaks = np.diff(stamps) > lost_gap_threshold(stamps, frame_period)
    if resumptions is not None and len(resumptions):
        breaks |= np.isin(stamps[1:], resumptions)
    return np.concatenate([[0], np.cumsum(breaks)])


def held_pose_errors(
    groundtruth: Trajectory,
    estimate: Trajectory,
    pose_alignment: np.ndarray,
    lost_intervals: list[tuple[float, float]],
    frame_period: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stamps and errors of the penalty samples inside the lost intervals.

    Samples lie every frame period (else median estimate period) inside each interval (so lost time weighs as
    much as tracked time); at each, the groundtruth is interpolated and compared with the
    aligned last estimate pose before it (zero-order hold; the first pose before the
    first). ``pose_alignment`` holds the transform ``(N, 4, 4)`` of each estimate pose;
    ``estimate`` stamps are on the groundtruth's clock.
    """
    period = (
        frame_period or median_period(estimate.timestamps) or median_period(groundtruth.timestamps) or MIN_LOST_GAP_S
    )
    samples = [np.arange(start + period, end, period) for start, end in lost_intervals]
    stamps = np.concatenate(samples) if samples else np.zeros(0)
    reference, covered = interpolate_poses(groundtruth, stamps)
    stamps, reference = stamps[covered], reference[covered]
    held = np.maximum(np.searchsorted(estimate.timestamps, stamps, side="right") - 1, 0)
    return stamps, absolute_errors(reference[:, :3, 3], estimate.positions[held], pose_alignment[held])
