"""How an estimate is laid onto the groundtruth before its ATE: one transform, or one per tracked segment.

A pipeline that loses tracking and starts again often continues in a new map frame; one
global fit then misplaces every segment a little to suit the largest one, and the error
shows at the wrong frames. Aligning each segment between lost intervals on its own keeps
each segment's error its own.
"""

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from ..geometry.align import align_origin, align_umeyama


class Alignment(StrEnum):
    """How an estimate is laid onto the groundtruth; the value is the name ``--align`` takes
    and reports record. Every kind but ``segments`` is one global transform."""

    RIGID = "rigid"
    SIM3 = "sim3"
    ORIGIN = "origin"
    SEGMENTS = "segments"
    NONE = "none"


MIN_SEGMENT_PAIRS = 3


def fit_alignment(kind: Alignment, estimate_poses: np.ndarray, reference_poses: np.ndarray) -> np.ndarray:
    """The 4x4 transform of ``kind`` (a global one: not ``segments``) over associated poses.

    rigid: Horn's least squares over positions; sim3: Umeyama's, with scale; origin: the
    first estimate pose laid onto the first groundtruth pose; none: the identity.
    """
    if kind == Alignment.NONE:
        return np.eye(4)
    if kind == Alignment.ORIGIN:
        return align_origin(estimate_poses[0], reference_poses[0])
    if kind in (Alignment.RIGID, Alignment.SIM3):
        return align_umeyama(estimate_poses[:, :3, 3], reference_poses[:, :3, 3], with_scale=kind == Alignment.SIM3)
    raise ValueError(f"alignment must be a global one, got {kind!r}")


def segment_alignments(
    kind: Alignment,
    estimate_poses: np.ndarray,
    reference_poses: np.ndarray,
    pair_segments: np.ndarray,
    segment_count: int,
) -> np.ndarray:
    """``(segment_count, 4, 4)``: each tracked segment's own transform of ``kind``, fitted on its pairs.

    ``pair_segments`` is the segment of each associated pair. A segment with fewer than
    :data:`MIN_SEGMENT_PAIRS` pairs cannot be fitted honestly (one or two poses can always
    be laid onto the groundtruth with ~0 error, wherever they are), so it takes the
    transform of the nearest earlier segment that was fitted: a pipeline that recovers in
    its map continues that map, and one that started a new map shows its error. Before
    the first fitted segment, the first fitted one's; with none fitted, the fit over all pairs.
    """
    counts = np.bincount(pair_segments, minlength=segment_count)
    donors = np.flatnonzero(counts >= MIN_SEGMENT_PAIRS)
    if len(donors) == 0:
        return np.broadcast_to(fit_alignment(kind, estimate_poses, reference_poses), (segment_count, 4, 4)).copy()
    by_segment = np.argsort(pair_segments, kind="stable")  # pair indices grouped by segment, in time order
    ends = np.cumsum(counts)
    pairs = [by_segment[ends[segment] - counts[segment] : ends[segment]] for segment in donors]
    transforms = np.stack([fit_alignment(kind, estimate_poses[index], reference_poses[index]) for index in pairs])
    earlier = np.searchsorted(donors, np.arange(segment_count), side="right") - 1
    return transforms[np.maximum(earlier, 0)]


@dataclass
class FittedAlignment:
    """The transforms an estimate is scored under, one ``(4, 4)`` per estimate pose in each array.

    ``transform`` is the global S (None for "segments"), ``per_pose`` what the ATE and the
    penalty use, ``per_segment`` each pose's own segment's transform.
    """

    transform: np.ndarray | None
    per_pose: np.ndarray
    per_segment: np.ndarray


def fit_estimate(
    kind: Alignment,
    estimate_poses: np.ndarray,
    reference_poses: np.ndarray,
    pose_segments: np.ndarray,
    matched: np.ndarray,
) -> FittedAlignment:
    """Fit ``kind`` and the per-segment alignment of the same kind.

    ``reference_poses`` are the groundtruth poses associated with the estimate poses at
    indices ``matched``; ``pose_segments`` numbers the tracked segment of every estimate pose.
    The segments are fitted rigidly for "segments".
    """
    segment_kind = Alignment.RIGID if kind == Alignment.SEGMENTS else kind
    by_segment = segment_alignments(
        segment_kind, estimate_poses[matched], reference_poses, pose_segments[matched], int(pose_segments[-1]) + 1
    )
    per_segment = by_segment[pose_segments]
    if kind == Alignment.SEGMENTS:
        return FittedAlignment(None, per_segment, per_segment)
    transform = fit_alignment(kind, estimate_poses[matched], reference_poses)
    return FittedAlignment(transform, np.broadcast_to(transform, per_segment.shape), per_segment)
