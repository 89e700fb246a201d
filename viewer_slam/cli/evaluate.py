"""`viewslam evaluate`: score a TUM trajectory file against groundtruth."""

from collections.abc import Iterator
from contextlib import contextmanager
from enum import Enum
from pathlib import Path

import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..dataset.tum import open_sequence
from ..errors import InputError
from ..evaluation import Evaluation, evaluate
from ..evaluation.report import write_report
from ..evaluation.statistics import STATISTICS, stats_or_none
from ..geometry.trajectory import Trajectory, read_tum
from .app import app


class DeltaUnit(str, Enum):
    frames = "frames"
    seconds = "seconds"


def _positive(value: float) -> float:
    if value <= 0:
        raise typer.BadParameter(f"must be positive, got {value}")
    return value


@app.command("evaluate")
def evaluate_command(
    groundtruth: Path = typer.Argument(..., help="Groundtruth trajectory (TUM format) or a TUM sequence folder."),
    estimate: Path = typer.Argument(..., help="Estimated trajectory (TUM format)."),
    json_path: Path | None = typer.Option(None, "--json", help="Write the metric blocks as JSON."),
    plot: Path | None = typer.Option(None, "--plot", help="Write a PNG: aligned top view and ATE over time."),
    max_difference: float = typer.Option(0.02, callback=_positive,
                                         help="Largest time difference of an associated pair, in seconds."),
    offset: float = typer.Option(0.0, help="Seconds added to the estimate's stamps before association."),
    scale: bool = typer.Option(False, "--scale", help="Fit a similarity (monocular estimates)."),
    delta: float = typer.Option(1.0, callback=_positive, help="RPE distance between poses."),
    delta_unit: DeltaUnit = typer.Option(DeltaUnit.seconds, help="Unit of --delta."),
    all_deltas: bool = typer.Option(False, "--all-deltas", help="RPE averaged over all distances (sampled)."),
) -> None:
    """ATE, RPE, coverage and penalised ATE of ESTIMATE against GROUNDTRUTH."""
    if delta_unit is DeltaUnit.frames and delta != int(delta):
        raise typer.BadParameter(f"a delta in frames must be a whole number, got {delta}", param_hint="--delta")
    reference, span, frame_period = _groundtruth_and_clock(groundtruth)
    estimated = read_tum(estimate)
    evaluation = evaluate(reference, estimated, max_difference=max_difference, offset=offset, scale=scale,
                          delta=delta, delta_unit=delta_unit.value, all_deltas=all_deltas, span=span,
                          frame_period=frame_period)
    if evaluation.ate is None:
        raise InputError.at(estimate, _why_no_pairs(reference, estimated, offset, max_difference))
    Console().print(_table(evaluation))
    if json_path is not None:
        with _writing(json_path):
            write_report(json_path, evaluation.to_dict())
    if plot is not None:
        from ..evaluation.plot import plot_evaluation  # matplotlib only when a plot is wanted

        with _writing(plot):
            plot_evaluation(plot, reference, estimated, evaluation)


@contextmanager
def _writing(path: Path) -> Iterator[None]:
    """Turn a failure to write ``path`` into a one-line input error."""
    try:
        yield
    except OSError as error:
        raise InputError.at(path, f"cannot write: {error.strerror}") from None


def _groundtruth_and_clock(path: Path) -> tuple[Trajectory, tuple[float, float] | None, float | None]:
    """A trajectory file, or a sequence folder's groundtruth with its frames' time span and period.

    With a folder, coverage is measured over the time the camera recorded, not over the
    groundtruth recorded before the first and after the last image, in units of its frame
    period.
    """
    if not path.is_dir():
        return read_tum(path), None, None
    sequence = open_sequence(path)
    if sequence.groundtruth is None:
        raise InputError.at(path, "sequence has no groundtruth.txt")
    return sequence.groundtruth, (float(sequence.timestamps[0]), float(sequence.timestamps[-1])), sequence.frame_period


def _why_no_pairs(groundtruth: Trajectory, estimate: Trajectory, offset: float, max_difference: float) -> str:
    start, end = estimate.timestamps[0] + offset, estimate.timestamps[-1] + offset
    gt_start, gt_end = groundtruth.timestamps[0], groundtruth.timestamps[-1]
    if end < gt_start or start > gt_end:
        return (f"no temporal overlap with the groundtruth (estimate {start:.3f}..{end:.3f} s, "
                f"groundtruth {gt_start:.3f}..{gt_end:.3f} s)")
    return f"no pose within {max_difference} s of a groundtruth pose"


def _table(evaluation: Evaluation) -> Table:
    coverage = evaluation.coverage
    rpe_pairs = "all Δ (sampled)" if evaluation.delta is None else f"Δ = {evaluation.delta:g} {evaluation.delta_unit}"
    table = Table(box=box.SIMPLE_HEAD, pad_edge=False, title=f"{len(evaluation.pairs[0])} associated pairs, coverage "
                  f"{coverage.ratio:.1%} ({len(coverage.lost_intervals)} lost intervals), RPE {rpe_pairs}")
    table.add_column("metric", no_wrap=True)
    for name in STATISTICS:
        table.add_column(name, justify="right")
    rows = [("ATE [m]", evaluation.ate), ("RPE trans [m]", evaluation.rpe_trans),
            ("RPE rot [deg]", evaluation.rpe_rot), ("penalised ATE [m]", evaluation.penalized_ate)]
    for label, series in rows:
        stats = stats_or_none(series)
        cells = ["-"] * len(STATISTICS) if stats is None else [
            str(stats[name]) if name == "n" else f"{stats[name]:.4f}" for name in STATISTICS]
        table.add_row(escape(label), *cells)
    return table
