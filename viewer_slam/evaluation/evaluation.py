"""Evaluate an estimated trajectory against groundtruth: ATE, RPE and coverage-aware scores."""

from dataclasses import dataclass

import numpy as np

from ..geometry.align import align_umeyama
from ..geometry.association import associate
from ..geometry.trajectory import Trajectory
from .ate import absolute_errors
from .coverage import Coverage, coverage, held_pose_errors
from .rpe import DELTA_UNITS, pairs_by_frames, pairs_by_seconds, relative_errors, sampled_pairs
from .statistics import ErrorSeries, stats_or_none

ALL_DELTAS_SAMPLES = 10_000


@dataclass
class Evaluation:
    """The scores of one estimate. Error series are None when there is nothing to score.

    ``alignment`` maps the estimate's frame onto the groundtruth's; ``pairs`` holds the
    associated indices ``(groundtruth, estimate)``. ``delta`` is None for all-Δ RPE.
    Error series are stamped on the estimate's clock; coverage intervals on the
    groundtruth's (estimate stamp + ``offset``).
    """

    ate: ErrorSeries | None
    rpe_trans: ErrorSeries | None
    rpe_rot: ErrorSeries | None
    coverage: Coverage
    penalized_ate: ErrorSeries | None
    alignment: np.ndarray | None
    pairs: tuple[np.ndarray, np.ndarray]
    delta: float | None
    delta_unit: str
    offset: float = 0.0

    def to_dict(self) -> dict:
        """The report blocks ``ate``, ``rpe``, ``coverage`` and ``penalized_ate``."""
        return {
            "ate": stats_or_none(self.ate),
            "rpe": {"trans": stats_or_none(self.rpe_trans), "rot": stats_or_none(self.rpe_rot),
                    "delta": self.delta, "delta_unit": self.delta_unit},
            "coverage": self.coverage.to_dict(),
            "penalized_ate": stats_or_none(self.penalized_ate),
        }


def evaluate(
    groundtruth: Trajectory,
    estimate: Trajectory,
    *,
    max_difference: float = 0.02,
    offset: float = 0.0,
    scale: bool = False,
    delta: float = 1.0,
    delta_unit: str = "seconds",
    all_deltas: bool = False,
    seed: int = 0,
    span: tuple[float, float] | None = None,
    frame_period: float | None = None,
) -> Evaluation:
    """Score ``estimate`` against ``groundtruth``, both in time order (definitions in docs/metrics.md).

    ``offset`` is added to the estimate's stamps; ``scale`` fits a similarity instead of a
    rigid alignment; RPE pairs are ``delta`` frames or seconds apart, or, with
    ``all_deltas``, a seeded sample over every distance. ``span`` is the time window that
    coverage measures (default: the groundtruth's; a sequence's first and last frame
    stamps avoid charging a method for groundtruth recorded before the camera started).
    ``frame_period`` is the sequence's frame period, the unit of the lost-gap threshold and
    of the penalty sampling (default: the estimate's median spacing).
    """
    if delta_unit not in DELTA_UNITS:
        raise ValueError(f"delta_unit must be one of {DELTA_UNITS}, got {delta_unit!r}")
    if delta <= 0 or (delta_unit == "frames" and delta != int(delta)):
        raise ValueError(f"delta must be a positive {'integer' if delta_unit == 'frames' else 'number'}, got {delta}")
    on_groundtruth_clock = Trajectory(estimate.timestamps + offset, estimate.poses)
    if span is None:
        span = (groundtruth.timestamps[0], groundtruth.timestamps[-1])
    covered = coverage(span, on_groundtruth_clock.timestamps, frame_period)
    reported_delta = None if all_deltas else (int(delta) if delta_unit == "frames" else float(delta))
    reported_unit = "all" if all_deltas else delta_unit

    gt_index, est_index = associate(groundtruth.timestamps, estimate.timestamps, offset, max_difference)
    if len(gt_index) == 0:
        return Evaluation(None, None, None, covered, None, None, (gt_index, est_index), reported_delta, reported_unit,
                          offset)

    reference, matched = groundtruth.poses[gt_index], estimate.poses[est_index]
    stamps = estimate.timestamps[est_index]
    alignment = align_umeyama(matched[:, :3, 3], reference[:, :3, 3], with_scale=scale)
    ate_errors = absolute_errors(reference[:, :3, 3], matched[:, :3, 3], alignment)

    if all_deltas:
        first, second = sampled_pairs(len(stamps), ALL_DELTAS_SAMPLES, seed)
    elif delta_unit == "frames":
        first, second = pairs_by_frames(len(stamps), int(delta))
    else:
        first, second = pairs_by_seconds(stamps, delta)
    metric_scale = matched.copy()  # RPE is alignment-free, but a similarity's scale must apply
    metric_scale[:, :3, 3] *= np.linalg.norm(alignment[:3, 0])
    rpe_trans, rpe_rot = relative_errors(reference, metric_scale, first, second)
    has_pairs = len(first) > 0

    penalty_stamps, penalty_errors = held_pose_errors(groundtruth, on_groundtruth_clock, alignment,
                                                      covered.lost_intervals, frame_period)
    penalized_stamps = np.concatenate([stamps, penalty_stamps - offset])
    order = np.argsort(penalized_stamps, kind="stable")
    penalized = ErrorSeries(penalized_stamps[order], np.concatenate([ate_errors, penalty_errors])[order])
    return Evaluation(
        ate=ErrorSeries(stamps, ate_errors),
        rpe_trans=ErrorSeries(stamps[second], rpe_trans) if has_pairs else None,
        rpe_rot=ErrorSeries(stamps[second], rpe_rot) if has_pairs else None,
        coverage=covered,
        penalized_ate=penalized,
        alignment=alignment,
        pairs=(gt_index, est_index),
        delta=reported_delta,
        delta_unit=reported_unit,
        offset=offset,
    )
