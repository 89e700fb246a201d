"""The summary of trajectory files scored against a groundtruth file, as Markdown.

A recording of trajectory files alone opens with this text beside the 3D view: which
file each run is, its scores, and when it was lost or stopped. It says how every number was
computed, since a figure without its alignment and pairs cannot be compared with another.
"""

from ..evaluation.statistics import ErrorSeries, stats_or_none
from .trajectory_files import ScoredFile, ScoredFiles

METHOD = (
    "Each estimate is scored as `viewslam evaluate` scores it: ATE and penalised ATE after one rigid "
    "alignment (Horn) of the whole run; ATE seg. with each tracked segment aligned rigidly on its own; "
    "RPE over Δ = 1 s, alignment-free. Coverage spans from the estimate's first pose to the groundtruth's "
    "last; times are seconds from that start."
)
COLUMNS = (
    "run",
    "file",
    "format",
    "poses",
    "pairs",
    "coverage",
    "ATE [m]",
    "ATE seg. [m]",
    "RPE trans [m]",
    "RPE rot [deg]",
    "penal. ATE [m]",
    "stopped at",
)


def _rmse(series: ErrorSeries | None) -> str:
    stats = stats_or_none(series)
    return "—" if stats is None else f"{stats['rmse']:.3f}"


def _row(run: ScoredFile) -> list[str]:
    evaluation = run.evaluation
    coverage = evaluation.coverage
    start, end = coverage.span.start, coverage.span.end
    stopped = coverage.stopped_at
    return [
        run.name,
        f"`{run.path.name}`",
        run.format,
        str(len(run.trajectory)),
        str(len(evaluation.pairs[0])),
        f"{coverage.ratio:.1%}",
        _rmse(evaluation.ate),
        _rmse(evaluation.segment_ate),
        _rmse(evaluation.rpe_trans),
        _rmse(evaluation.rpe_rot),
        _rmse(evaluation.penalized_ate),
        "—" if stopped is None else f"{stopped - start:.1f} of {end - start:.1f} s",
    ]


def _losses(run: ScoredFile) -> str:
    coverage = run.evaluation.coverage
    start = coverage.span.start
    if not coverage.lost_intervals:
        return f"- {run.name}: never lost"
    intervals = ", ".join(
        f"{lost_start - start:.1f} to {lost_end - start:.1f} s"
        + (" (stopped)" if lost_start == coverage.stopped_at else "")
        for lost_start, lost_end in coverage.lost_intervals
    )
    return f"- {run.name}: {intervals}"


def summary_markdown(scored: ScoredFiles) -> str:
    """The title, a table of the runs' scores, each run's lost intervals, then how the figures were
    computed and the groundtruth: the numbers first, where a small window shows them."""
    stamps = scored.groundtruth.timestamps
    lines = [
        f"# {', '.join(run.name for run in scored.runs)} against {scored.name}",
        "",
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "---|" * len(COLUMNS),
    ]
    lines += ["| " + " | ".join(_row(run)) + " |" for run in scored.runs]
    lines += ["", "Lost intervals (no pose for longer than the gap rule of docs/metrics.md):", ""]
    lines += [_losses(run) for run in scored.runs]
    lines += [
        "",
        METHOD,
        "",
        f"Groundtruth `{scored.groundtruth_path}`: {len(stamps)} poses over {stamps[-1] - stamps[0]:.1f} s.",
    ]
    return "\n".join(lines) + "\n"
