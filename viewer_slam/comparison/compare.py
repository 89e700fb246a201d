"""Two runs of one sequence, frame by frame: errors, frames only one tracked, losses, parameters, scores.

Run B is compared against run A: every difference is B minus A. Both trajectories are
evaluated again against the sequence's groundtruth (the same evaluation as the reports'),
so the per-frame errors can be set side by side at each frame.

A run block of a benchmark that ran trials lists every trial's scores (``trials``); its
summary scores are then the medians over the trials, and a difference is said to exceed
the trials' spread when the two sides' min–max ranges do not overlap (a side with one run
being its one value).
"""

import statistics
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.sources import RgbdSequence, open_source
from ..errors import InputError
from ..evaluation import evaluate
from ..geometry.association import associate
from ..geometry.trajectory import Trajectory
from .reports import RecordedRun, RecordReport, load_report

STAMP_TOLERANCE_S = 1e-5
"""Trajectory files keep micro-seconds: a pose is at a frame whose stamp is this close."""

SUMMARY = (  # label, path into a run block
    ("poses", ("frames_with_pose",)),
    ("coverage", ("coverage", "ratio")),
    ("ATE RMSE [m]", ("ate", "rmse")),
    ("penalised ATE RMSE [m]", ("penalized_ate", "rmse")),
    ("RPE trans RMSE [m]", ("rpe", "trans", "rmse")),
    ("RPE rot RMSE [deg]", ("rpe", "rot", "rmse")),
    ("loop closures", ("loop_closures", "accepted")),
    ("keyframes", ("keyframes",)),
    ("frames/s", ("timing", "fps")),
)
PIPELINE_ONLY = {"loop closures", "keyframes", "frames/s"}
"""Scores a pipeline measures and an estimate replayed from a file does not have."""


@dataclass
class RunComparison:
    """Run ``b`` against run ``a`` over the sequence's frames.

    ``ate_a``/``ate_b`` hold one error per sequence frame (NaN where the run had no pose
    or there is no groundtruth) under the run's ``alignment_a``/``alignment_b`` onto the
    groundtruth; ``summary`` maps a score's label to ``(a, b)`` (medians over trials where a
    run has them); ``spread`` the scores' ``(min, max)`` over each side's trials, for the
    labels where a side has more than one; ``parameters`` the values that differ, None for
    runs with no parameter in common (two different methods).
    """

    a: RecordedRun
    b: RecordedRun
    frame_indices: np.ndarray
    timestamps: np.ndarray
    ate_a: np.ndarray
    ate_b: np.ndarray
    alignment_a: np.ndarray | None
    alignment_b: np.ndarray | None
    tracked_a: np.ndarray
    tracked_b: np.ndarray
    summary: dict[str, tuple[Any, Any]]
    parameters: dict[str, tuple[Any, Any]] | None
    losses_vanished: list[dict[str, Any]]
    losses_appeared: list[dict[str, Any]]
    spread: dict[str, tuple[tuple[float, float] | None, tuple[float, float] | None]] = field(default_factory=dict)

    @property
    def has_trials(self) -> bool:
        """Whether either run is a benchmark pair's trials (so the spread can be weighed)."""
        return bool(self.a.block.get("trials") or self.b.block.get("trials"))

    def beyond_spread(self, label: str) -> bool | None:
        """Whether B's and A's values of ``label`` lie apart: their ranges over the trials do not overlap.
        None when no side has a spread of the score, or a side has no value."""
        a, b = self.summary[label]
        spread_a, spread_b = self.spread.get(label, (None, None))
        if (spread_a is None and spread_b is None) or not numeric(a, b):
            return None
        low_a, high_a = spread_a or (a, a)
        low_b, high_b = spread_b or (b, b)
        return low_b > high_a or high_b < low_a

    @property
    def ate_difference(self) -> np.ndarray:
        """B's error minus A's at each frame both tracked (NaN elsewhere)."""
        return self.ate_b - self.ate_a

    @property
    def frames_only_a(self) -> np.ndarray:
        return self.frame_indices[self.tracked_a & ~self.tracked_b]

    @property
    def frames_only_b(self) -> np.ndarray:
        return self.frame_indices[self.tracked_b & ~self.tracked_a]


@dataclass
class Comparison:
    a: RecordReport
    b: RecordReport
    sequence: RgbdSequence
    runs: list[RunComparison]


def compare_reports(path_a: Path, path_b: Path, runs: tuple[str, str] | None = None) -> Comparison:
    """Load both reports, check they are of one sequence, and compare their runs pairwise:
    those of the same name, or with ``runs`` = (name in A, name in B) that one pair, so two
    methods (or a report against itself) can be compared."""
    a, b = load_report(path_a), load_report(path_b)
    check_same_sequence(a, b)
    pairs = run_pairs(a, b) if runs is None else [named_pair(a, b, *runs)]
    sequence = open_compared_sequence(a, b)
    return Comparison(a, b, sequence, [compare_runs(run_a, run_b, sequence) for run_a, run_b in pairs])


def named_pair(a: RecordReport, b: RecordReport, name_a: str, name_b: str) -> tuple[RecordedRun, RecordedRun]:
    """Run ``name_a`` of report A and ``name_b`` of report B; a missing name is refused with what there is."""
    for report, name in ((a, name_a), (b, name_b)):
        if name not in report.runs:
            raise InputError.at(report.path, f"has no run {name!r} (its runs: {', '.join(report.runs)})")
    return a.runs[name_a], b.runs[name_b]


def same_sequence(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether two reports' sequence blocks describe one sequence: the same name and number of frames."""
    return a.get("name") == b.get("name") and a.get("frames") == b.get("frames")


def check_same_sequence(a: RecordReport, b: RecordReport) -> None:
    """Refuse reports of different sequences (by name and frame count), naming both."""
    if not same_sequence(a.sequence, b.sequence):
        raise InputError(
            f"{a.path} and {b.path} are reports of different sequences "
            f"({a.sequence.get('name')}, {a.sequence.get('frames')} frames; "
            f"{b.sequence.get('name')}, {b.sequence.get('frames')} frames)"
        )


def run_pairs(a: RecordReport, b: RecordReport) -> list[tuple[RecordedRun, RecordedRun]]:
    """Runs of the same name; two reports of one run each are paired whatever the names."""
    common = [name for name in a.runs if name in b.runs]
    if common:
        return [(a.runs[name], b.runs[name]) for name in common]
    if len(a.runs) == len(b.runs) == 1:
        return [(next(iter(a.runs.values())), next(iter(b.runs.values())))]
    raise InputError(f"{a.path} and {b.path} share no run to compare ({', '.join(a.runs)}; {', '.join(b.runs)})")


def compare_runs(a: RecordedRun, b: RecordedRun, sequence: RgbdSequence) -> RunComparison:
    stamps = np.asarray(sequence.timestamps, dtype=np.float64)
    tracked_a, tracked_b = _tracked(a.trajectory, stamps), _tracked(b.trajectory, stamps)
    (ate_a, alignment_a), (ate_b, alignment_b) = (
        _frame_errors(a.trajectory, sequence),
        _frame_errors(b.trajectory, sequence),
    )
    scores = {
        label: (_trial_score(a.block, label, keys), _trial_score(b.block, label, keys)) for label, keys in SUMMARY
    }
    return RunComparison(
        a=a,
        b=b,
        frame_indices=np.arange(len(stamps)),
        timestamps=stamps,
        ate_a=ate_a,
        ate_b=ate_b,
        alignment_a=alignment_a,
        alignment_b=alignment_b,
        tracked_a=tracked_a,
        tracked_b=tracked_b,
        summary={label: (a_score[0], b_score[0]) for label, (a_score, b_score) in scores.items()},
        parameters=_parameter_differences(a.block["parameters"], b.block["parameters"]),
        losses_vanished=_unmatched_losses(a.block["tracking_lost"], b.block["tracking_lost"], tracked_b),
        losses_appeared=_unmatched_losses(b.block["tracking_lost"], a.block["tracking_lost"], tracked_a),
        spread={
            label: (a_score[1], b_score[1])
            for label, (a_score, b_score) in scores.items()
            if a_score[1] is not None or b_score[1] is not None
        },
    )


def _trial_score(block: dict[str, Any], label: str, keys: tuple[str, ...]) -> tuple[Any, tuple[float, float] | None]:
    """A score of a run block and its ``(min, max)``: without trials, the block's own value and no
    spread; with them, the median over the trials that ran and, when more than one has it, their range."""
    trials = block.get("trials")
    if not trials:
        return _score(block, label, keys), None
    values = [value for trial in trials if trial.get("status") == "ok" if numeric(value := _lookup(trial, keys))]
    if not values:
        return None, None
    return statistics.median(values), (min(values), max(values)) if len(values) > 1 else None


def numeric(*values: Any) -> bool:
    """Whether every value is a number (a bool is not, though Python counts it as an int)."""
    return all(isinstance(value, (int, float)) and not isinstance(value, bool) for value in values)


def open_compared_sequence(a: RecordReport, b: RecordReport) -> RgbdSequence:
    """The sequence folder either report names (the first that still exists)."""
    paths = [Path(report.sequence["path"]) for report in (a, b) if report.sequence.get("path")]
    for path in paths:
        if path.is_dir():
            return open_source(path)
    raise InputError.at(
        a.path,
        f"the sequence folder it names is gone ({paths[0] if paths else 'no path'}); "
        f"the groundtruth is needed to compare the errors",
    )


def _frames_at(pose_stamps: np.ndarray, frame_stamps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sequence frame, row of ``pose_stamps``) of every stamp that is a frame's."""
    return associate(frame_stamps, pose_stamps, max_difference=STAMP_TOLERANCE_S)


def _tracked(trajectory: Trajectory, stamps: np.ndarray) -> np.ndarray:
    tracked = np.zeros(len(stamps), dtype=bool)
    tracked[_frames_at(trajectory.timestamps, stamps)[0]] = True
    return tracked


def _frame_errors(trajectory: Trajectory, sequence: RgbdSequence) -> tuple[np.ndarray, np.ndarray | None]:
    """The run's ATE at each frame (NaN: none) and the alignment it is measured under."""
    errors = np.full(len(sequence), np.nan)
    if sequence.groundtruth is None or len(trajectory) == 0:
        return errors, None
    evaluation = evaluate(sequence.groundtruth, trajectory, frame_period=sequence.frame_period)
    if evaluation.ate is not None:
        frames, rows = _frames_at(evaluation.ate.timestamps, np.asarray(sequence.timestamps, dtype=np.float64))
        errors[frames] = evaluation.ate.errors[rows]
    return errors, evaluation.alignment


def _score(block: dict[str, Any], label: str, keys: tuple[str, ...]) -> Any:
    if label in PIPELINE_ONLY and block.get("source") == "estimate":
        return None
    return _lookup(block, keys)


def _lookup(block: dict[str, Any], keys: tuple[str, ...]) -> Any:
    value: Any = block
    for key in keys:
        if not isinstance(value, dict):
            return None
        value = value.get(key)
    return value


def _parameter_differences(a: dict[str, Any], b: dict[str, Any]) -> dict[str, tuple[Any, Any]] | None:
    if (a or b) and not set(a) & set(b):
        return None
    return {key: (a.get(key), b.get(key)) for key in [*a, *(k for k in b if k not in a)] if a.get(key) != b.get(key)}


def _unmatched_losses(
    losses: list[dict[str, Any]], others: list[dict[str, Any]], other_tracked: np.ndarray
) -> list[dict[str, Any]]:
    """``losses`` at frames where the other run lost nothing, with whether it was tracking there."""
    other_frames = {loss["frame"] for loss in others}
    return [
        {**loss, "other_tracking": bool(loss["frame"] < len(other_tracked) and other_tracked[loss["frame"]])}
        for loss in losses
        if loss["frame"] not in other_frames
    ]
