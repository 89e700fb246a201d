"""Evaluate an estimated trajectory against groundtruth: ATE, RPE and coverage-aware scores."""

from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np

from ..geometry.association import associate
from ..geometry.trajectory import Trajectory
from .alignment import Alignment, fit_estimate
from .ate import absolute_errors
from .coverage import Coverage, Span, coverage, file_span, held_pose_errors, tracked_segments
from .rpe import DeltaUnit, pairs_by_frames, pairs_by_seconds, relative_errors, sampled_pairs
from .statistics import ErrorSeries, stats_or_none
from .tum_rpe import tum_rpe

ALL_DELTAS_SAMPLES = 10_000


class RpeMode(StrEnum):
    """Which pose pairs RPE scores; the value is the name ``--rpe-mode`` takes and reports record."""

    DELTA = "delta"  # pairs Δ apart, or viewslam's all-Δ sample
    TUM = "tum"  # TUM evaluate_rpe.py's default pairs and error (:mod:`.tum_rpe`)


@dataclass
class Evaluation:
    """The scores of one estimate. Error series are None when there is nothing to score.

    ``alignment_name`` says how ``ate`` and ``penalized_ate`` were aligned; ``alignment`` is that global transform S from the
    estimate's frame onto the groundtruth's (None with "segments"), and ``pose_alignment``
    the transform each estimate pose was scored under. ``segment_ate`` aligns every
    tracked segment on its own. ``pairs`` holds the associated indices
    ``(groundtruth, estimate)``. ``delta`` is None for all-Δ RPE. ``rpe_mode`` is "delta"
    (pairs Δ apart, or viewslam's all-Δ sample) or "tum" (TUM evaluate_rpe.py's default pairs
    and error, :mod:`.tum_rpe`). Error series are stamped
    on the estimate's clock; coverage intervals on the groundtruth's (estimate stamp + ``offset``).
    """

    ate: ErrorSeries | None
    segment_ate: ErrorSeries | None
    rpe_trans: ErrorSeries | None
    rpe_rot: ErrorSeries | None
    coverage: Coverage
    penalized_ate: ErrorSeries | None
    alignment_name: Alignment
    alignment: np.ndarray | None
    pose_alignment: np.ndarray | None
    pairs: tuple[np.ndarray, np.ndarray]
    delta: float | None
    delta_unit: str  # a DeltaUnit, or "all" for all-Δ RPE
    offset: float = 0.0
    rpe_mode: RpeMode = RpeMode.DELTA
    node_ate: ErrorSeries | None = None

    def to_dict(self) -> dict[str, Any]:
        """The report blocks ``alignment``, ``ate``, ``ate_segments``, ``rpe``, ``coverage`` and ``penalized_ate``."""
        return {
            "alignment": self.alignment_name,
            "ate": stats_or_none(self.ate),
            "ate_segments": stats_or_none(self.segment_ate),
            "rpe": {
                "trans": stats_or_none(self.rpe_trans),
                "rot": stats_or_none(self.rpe_rot),
                "delta": self.delta,
                "delta_unit": self.delta_unit,
                "mode": self.rpe_mode,
            },
            "coverage": self.coverage.to_dict(),
            "penalized_ate": stats_or_none(self.penalized_ate),
        }

    def pose_errors(self, count: int) -> np.ndarray:
        """The ATE error of each of the estimate's ``count`` poses, NaN for a pose without a groundtruth
        pair: what a view colours each pose by."""
        errors = np.full(count, np.nan)
        if self.ate is not None:
            errors[self.pairs[1]] = self.ate.errors
        return errors

    def aligned_positions(self, estimate: Trajectory) -> np.ndarray | None:
        """The estimate's positions in the groundtruth frame, as its ATE saw them (None without pairs)."""
        if self.pose_alignment is None:
            return None
        rotations, translations = self.pose_alignment[:, :3, :3], self.pose_alignment[:, :3, 3]
        aligned: np.ndarray = np.einsum("nij,nj->ni", rotations, estimate.positions) + translations
        return aligned


def evaluate(
    groundtruth: Trajectory,
    estimate: Trajectory,
    *,
    max_difference: float = 0.02,
    offset: float = 0.0,
    scale: bool = False,
    align: Alignment = Alignment.RIGID,
    delta: float = 1.0,
    delta_unit: DeltaUnit = DeltaUnit.SECONDS,
    all_deltas: bool = False,
    seed: int = 0,
    span: Span | tuple[float, float] | None = None,
    frame_period: float | None = None,
    rpe_mode: RpeMode = RpeMode.DELTA,
) -> Evaluation:
    """Score ``estimate`` against ``groundtruth``, both in time order (definitions in docs/metrics.md).

    ``offset`` is added to the estimate's stamps. ``align`` and ``delta_unit`` may also be
    given by their values (``"sim3"``, ``"frames"``); ``scale`` is the older spelling of
    ``align="sim3"``.
    The segment-aligned ATE fits each tracked segment with the same kind of alignment
    (rigid with "segments"). RPE pairs are ``delta`` frames or seconds apart, or, with
    ``all_deltas``, a seeded sample over every distance. ``span`` is the time window that
    coverage measures (default :func:`~.coverage.file_span`: from the later of the two
    first stamps to the groundtruth's end; a sequence's first and last frame stamps when
    the caller knows them). ``frame_period`` is the sequence's frame period, the unit of
    the lost-gap threshold and of the penalty sampling (default: the estimate's median spacing).
    ``rpe_mode="tum"`` scores RPE as TUM's evaluate_rpe.py does by default (``delta`` and
    ``all_deltas`` then do not apply), so published figures can be replayed digit for digit.
    """
    if rpe_mode not in tuple(RpeMode):
        raise ValueError(f"rpe_mode must be one of {', '.join(RpeMode)}, got {rpe_mode!r}")
    rpe_mode = RpeMode(rpe_mode)
    if rpe_mode == RpeMode.TUM and all_deltas:
        raise ValueError("rpe_mode 'tum' draws its own pairs and cannot be combined with all_deltas")
    if delta_unit not in tuple(DeltaUnit):
        raise ValueError(f"delta_unit must be one of {', '.join(DeltaUnit)}, got {delta_unit!r}")
    delta_unit = DeltaUnit(delta_unit)
    if not (np.isfinite(delta) and delta > 0) or (delta_unit == DeltaUnit.FRAMES and delta != int(delta)):
        kind = "integer" if delta_unit == DeltaUnit.FRAMES else "number"
        raise ValueError(f"delta must be a positive {kind}, got {delta}")
    if align not in tuple(Alignment) or (scale and align not in (Alignment.RIGID, Alignment.SIM3)):
        raise ValueError(f"align must be one of {', '.join(Alignment)} (scale=True means 'sim3'), got {align!r}")
    align = Alignment.SIM3 if scale else Alignment(align)
    on_groundtruth_clock = Trajectory(estimate.timestamps + offset, estimate.poses)
    if span is None:
        span = file_span(groundtruth.timestamps, on_groundtruth_clock.timestamps)
    covered = coverage(span, on_groundtruth_clock.timestamps, frame_period, groundtruth, estimate.resumptions + offset)
    every_delta = all_deltas or rpe_mode == RpeMode.TUM
    reported_delta = None if every_delta else (int(delta) if delta_unit == DeltaUnit.FRAMES else float(delta))
    reported_unit = "all" if every_delta else delta_unit

    gt_index, est_index = associate(groundtruth.timestamps, estimate.timestamps, offset, max_difference)
    if len(gt_index) == 0:
        return Evaluation(
            ate=None,
            segment_ate=None,
            rpe_trans=None,
            rpe_rot=None,
            coverage=covered,
            penalized_ate=None,
            alignment_name=align,
            alignment=None,
            pose_alignment=None,
            pairs=(gt_index, est_index),
            delta=reported_delta,
            delta_unit=reported_unit,
            offset=offset,
            rpe_mode=rpe_mode,
        )

    reference, matched = groundtruth.poses[gt_index], estimate.poses[est_index]
    stamps = estimate.timestamps[est_index]
    fitted = fit_estimate(
        align,
        estimate.poses,
        reference,
        tracked_segments(estimate.timestamps, frame_period, estimate.resumptions),
        est_index,
    )
    ate_errors = absolute_errors(reference[:, :3, 3], matched[:, :3, 3], fitted.per_pose[est_index])
    segment_errors = absolute_errors(reference[:, :3, 3], matched[:, :3, 3], fitted.per_segment[est_index])

    if all_deltas:
        first, second = sampled_pairs(len(stamps), ALL_DELTAS_SAMPLES, seed)
    elif delta_unit == DeltaUnit.FRAMES:
        first, second = pairs_by_frames(len(stamps), int(delta))
    else:
        first, second = pairs_by_seconds(stamps, delta)
    sim3_scale = (
        float(np.linalg.norm(fitted.transform[:3, 0]))
        if align == Alignment.SIM3 and fitted.transform is not None
        else 1.0
    )
    metric_scale = matched.copy()  # RPE is alignment-free, but a similarity's scale must apply
    if align == Alignment.SIM3:
        metric_scale[:, :3, 3] *= sim3_scale
    rpe_trans, rpe_rot = relative_errors(reference, metric_scale, first, second)
    has_pairs = len(first) > 0
    rpe_stamps = stamps[second]
    if rpe_mode == RpeMode.TUM:
        rpe_stamps, rpe_trans, rpe_rot = _tum_rpe(groundtruth, estimate, offset, sim3_scale)
        has_pairs = len(rpe_stamps) > 0

    penalty_stamps, penalty_errors = held_pose_errors(
        groundtruth, on_groundtruth_clock, fitted.per_pose, covered.lost_intervals, frame_period
    )
    penalized_stamps = np.concatenate([stamps, penalty_stamps - offset])
    order = np.argsort(penalized_stamps, kind="stable")
    penalized = ErrorSeries(penalized_stamps[order], np.concatenate([ate_errors, penalty_errors])[order])
    return Evaluation(
        ate=ErrorSeries(stamps, ate_errors),
        segment_ate=ErrorSeries(stamps, segment_errors),
        rpe_trans=ErrorSeries(rpe_stamps, rpe_trans) if has_pairs else None,
        rpe_rot=ErrorSeries(rpe_stamps, rpe_rot) if has_pairs else None,
        coverage=covered,
        penalized_ate=penalized,
        alignment_name=align,
        alignment=fitted.transform,
        pose_alignment=fitted.per_pose,
        pairs=(gt_index, est_index),
        delta=reported_delta,
        delta_unit=reported_unit,
        offset=offset,
        rpe_mode=rpe_mode,
    )


def why_no_pairs(
    groundtruth: Trajectory, estimate: Trajectory, offset: float = 0.0, max_difference: float = 0.02
) -> str:
    """Why ``estimate`` has no pose pair with ``groundtruth``: no overlap in time, or none close enough."""
    start, end = estimate.timestamps[0] + offset, estimate.timestamps[-1] + offset
    gt_start, gt_end = groundtruth.timestamps[0], groundtruth.timestamps[-1]
    if end < gt_start or start > gt_end:
        return (
            f"no temporal overlap with the groundtruth (estimate {start:.3f}..{end:.3f} s, "
            f"groundtruth {gt_start:.3f}..{gt_end:.3f} s)"
        )
    return f"no pose within {max_difference} s of a groundtruth pose"


def _tum_rpe(
    groundtruth: Trajectory, estimate: Trajectory, offset: float, scale: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stamps (the second pose of each pair), translation [m] and rotation [deg] of TUM's default
    RPE; empty where the script would give up (fewer than two comparable pairs)."""
    try:
        result = tum_rpe(
            groundtruth.timestamps, groundtruth.poses, estimate.timestamps, estimate.poses, offset=offset, scale=scale
        )
    except ValueError:
        empty = np.zeros(0)
        return empty, empty, empty
    order = np.argsort(result.second_stamps, kind="stable")  # in time, for plots and timelines
    return result.second_stamps[order], result.translation[order], np.degrees(result.rotation[order])
