"""What ``viewslam evaluate`` prints: the legend of the columns (which alignment each uses), one
table row per estimate, and for each estimate the format it was read as and its coverage span."""

from rich import box
from rich.markup import escape
from rich.table import Table

from ..evaluation.alignment import Alignment
from ..evaluation.evaluation import Evaluation, RpeMode
from ..evaluation.rpe import DeltaUnit
from ..evaluation.statistics import ErrorSeries, stats_or_none
from ..geometry.trajectory_formats import TrajectoryFormat
from ..terminal import print_table
from .evaluate_command import EvaluateResult
from .trajectory_files import BAG_FORMAT

FORMAT_NAMES = {
    TrajectoryFormat.TUM: "TUM",
    TrajectoryFormat.KITTI: "KITTI",
    TrajectoryFormat.EUROC: "EuRoC",
    TrajectoryFormat.RTABMAP: "an RTAB-Map database",
    BAG_FORMAT: "a ROS bag's pose topic",
}

GLOBAL_ALIGNMENT_TEXT = {
    Alignment.RIGID: "rigid alignment (Horn) over all pairs",
    Alignment.SIM3: "similarity alignment (Umeyama, with scale) over all pairs",
    Alignment.ORIGIN: "first poses laid onto each other (origin alignment)",
    Alignment.NONE: "no alignment",
    Alignment.SEGMENTS: "each tracked segment aligned rigidly on its own",
}
SEGMENT_ALIGNMENT_TEXT = {
    Alignment.RIGID: "each tracked segment aligned rigidly on its own",
    Alignment.SIM3: "each tracked segment aligned by a similarity on its own",
    Alignment.ORIGIN: "each tracked segment's first pose laid onto the groundtruth",
    Alignment.NONE: "no alignment",
    Alignment.SEGMENTS: "each tracked segment aligned rigidly on its own",
}


def plural(count: float, noun: str) -> str:
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def print_results(result: EvaluateResult) -> None:
    """The legend, the table and the per-estimate lines on stdout."""
    first = result.estimates[0].evaluation
    if first.rpe_mode == RpeMode.TUM:
        from ..evaluation.tum_rpe import MODE_TEXT

        rpe_pairs = MODE_TEXT
    elif first.delta is None:
        rpe_pairs = "all Δ (sampled)"
    elif first.delta_unit == DeltaUnit.SECONDS:
        rpe_pairs = f"Δ = {first.delta:g} s"
    else:
        rpe_pairs = f"Δ = {plural(first.delta, 'frame')}"
    lines = [
        f"RMSE against {result.groundtruth.path}",
        f"  ATE, penal. ATE [m]: {GLOBAL_ALIGNMENT_TEXT[first.alignment_name]}",
        f"  ATE seg. [m]: {SEGMENT_ALIGNMENT_TEXT[first.alignment_name]}",
        f"  RPE trans [m], rot [deg]: alignment-free, {rpe_pairs}",
    ]
    table = Table(box=box.SIMPLE_HEAD, pad_edge=False, show_edge=False)
    for column in ("estimate", "pairs", "coverage", "ATE", "ATE seg.", "RPE trans", "RPE rot", "penal. ATE"):
        table.add_column(column, justify="left" if column == "estimate" else "right", no_wrap=True)
    for run in result.estimates:
        table.add_row(escape(run.name), *_row(run.evaluation))
    print("\n".join(lines))
    print_table(table)
    print(
        "\n".join(
            f"{run.name}: read as {FORMAT_NAMES[run.format]}; {_coverage_text(run.evaluation)}"
            for run in result.estimates
        )
    )


def _row(evaluation: Evaluation) -> list[str]:
    def rmse(series: ErrorSeries | None) -> str:
        stats = stats_or_none(series)
        return "—" if stats is None else f"{stats['rmse']:.4f}"

    return [
        str(len(evaluation.pairs[0])),
        f"{evaluation.coverage.ratio:.1%}",
        rmse(evaluation.ate),
        rmse(evaluation.segment_ate),
        rmse(evaluation.rpe_trans),
        rmse(evaluation.rpe_rot),
        rmse(evaluation.penalized_ate),
    ]


def _coverage_text(evaluation: Evaluation) -> str:
    span = evaluation.coverage.span
    lost = len(evaluation.coverage.lost_intervals)
    return (
        f"coverage over {span.start:.6f}..{span.end:.6f} ({span.end - span.start:.3f} s, {span.rule}), "
        f"{plural(lost, 'lost interval')}"
    )
