"""``viewslam evaluate`` as a library function: trajectory files scored against a groundtruth,
the metric blocks and a picture written.

The files are read and scored by the one scoring path (:mod:`.trajectory_files`), which
``record --groundtruth`` and ``study`` share, so the three accept the same inputs and give the
same numbers.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..atomic import StagedFiles, check_writable, refuse_inputs_as_outputs
from ..errors import InputError
from ..evaluation.evaluation import RpeMode
from ..evaluation.rpe import DeltaUnit
from .run_report import write_report
from .trajectory_files import (
    Groundtruth,
    ScoredFile,
    ScoringOptions,
    read_groundtruth,
    read_sequence_clock,
    score_files,
)


@dataclass(frozen=True)
class EvaluateResult:
    """What ``evaluate`` scored: the groundtruth (with the clock its coverage used), every estimate
    with its scores, in the order given (each named by its path as given), and the files written."""

    groundtruth: Groundtruth
    estimates: tuple[ScoredFile, ...]
    written: tuple[Path, ...] = ()

    def report(self) -> dict[str, Any]:
        """What ``--json`` writes: one estimate's metric blocks, or every estimate's by name."""
        blocks = {run.name: run.evaluation.to_dict() for run in self.estimates}
        if len(blocks) == 1:
            return next(iter(blocks.values()))
        return {"groundtruth": str(self.groundtruth.path), "estimates": blocks}


def evaluate(
    groundtruth: Path,
    estimates: Sequence[Path],
    *,
    options: ScoringOptions = ScoringOptions(),
    sequence: Path | None = None,
    format: str | None = None,
    groundtruth_topic: str | None = None,
    estimate_topic: str | None = None,
    json: Path | None = None,
    plot: Path | None = None,
) -> EvaluateResult:
    """Score every estimate against ``groundtruth`` with ``options``; write the metric blocks to
    ``json`` and the aligned top view and errors over time to ``plot`` (any format matplotlib
    writes, by its extension).

    ``groundtruth`` is a trajectory file (TUM or EuRoC), a TUM sequence folder or a ROS bag
    (``groundtruth_topic``: its pose topic); a sequence's frames set the coverage span, the
    frame period and a KITTI file's times, as ``sequence`` (a folder or bag) does when given.
    Estimates are TUM, KITTI, EuRoC files or RTAB-Map databases (read in ``format``, else
    detected) or ROS bags (``estimate_topic``). The outputs are checked before anything is
    read, never replace an input, and are renamed into place together once all are written.
    Bad input is an :class:`~viewer_slam.errors.InputError` naming the file.
    """
    estimates = [Path(path) for path in estimates]
    _check_options(options)
    if plot is not None:
        from ..evaluation.plot import check_plot_path  # matplotlib only when a plot is wanted

        check_plot_path(plot)
    outputs = {path: option for path, option in ((json, "--json"), (plot, "--plot")) if path is not None}
    refuse_inputs_as_outputs(
        outputs,
        {
            path: f"{what} {path}"
            for path, what in (
                (groundtruth, "GROUNDTRUTH"),
                *((estimate, "ESTIMATE") for estimate in estimates),
                (sequence, "--sequence"),
            )
            if path is not None
        },
    )
    for output in outputs:
        check_writable(output)
    reference = read_groundtruth(groundtruth, groundtruth_topic)
    if sequence is not None:
        reference = replace(reference, clock=read_sequence_clock(sequence))
    labels = [str(path) for path in estimates]
    repeated = next((path for path, label in zip(estimates, labels) if labels.count(label) > 1), None)
    if repeated is not None:
        raise InputError.at(repeated, "given twice as an estimate")
    scored = score_files(reference, list(zip(labels, estimates)), format, options=options, topic=estimate_topic)
    result = EvaluateResult(reference, tuple(scored.runs))
    writers: dict[Path, Callable[[Path], None]] = {}
    if json is not None:
        report = result.report()
        writers[json] = lambda path: write_report(path, report)
    if plot is not None:
        writers[plot] = lambda path: _plot(path, result, plot.suffix.lstrip(".").lower())
    _write_together(writers)
    return replace(result, written=tuple(writers))


def _check_options(options: ScoringOptions) -> None:
    if options.rpe_mode is RpeMode.TUM and (
        options.all_deltas or options.delta != 1.0 or options.delta_unit is not DeltaUnit.SECONDS
    ):
        raise InputError(
            "--rpe-mode tum draws its own pose pairs and cannot be combined with --delta, --delta-unit or --all-deltas"
        )


def _plot(path: Path, result: EvaluateResult, format: str) -> None:
    from ..evaluation.plot import Scored, plot_evaluation

    scored = [Scored(Path(run.name).name, run.trajectory, run.evaluation) for run in result.estimates]
    plot_evaluation(path, result.groundtruth.trajectory, scored, format=format)


def _write_together(writers: dict[Path, Callable[[Path], None]]) -> None:
    """Each target written by its writer under a temporary name beside it, then all renamed into
    place together: a failure to write one (a full disk) is a one-line input error naming it, and
    leaves every target as it was."""
    with StagedFiles() as staged:
        for target, write in writers.items():
            try:
                write(staged.path(target))
            except OSError as error:
                raise InputError.at(target, f"cannot write: {error.strerror or error}") from None
        staged.commit()
