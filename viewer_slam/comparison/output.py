"""A comparison as JSON and as the terminal table of `viewslam diff`."""

import math
from typing import Any

import numpy as np
from rich import box
from rich.console import Console
from rich.table import Table

from ..terminal import StdoutConsole, print_table
from .compare import Comparison, RunComparison, numeric
from .results import ResultsComparison


def frame_ranges(frames: np.ndarray) -> str:
    """``[3, 4, 5, 9]`` -> ``"3-5, 9"``: consecutive frames as one range."""
    frames = np.asarray(frames, dtype=int)
    if not len(frames):
        return "none"
    breaks = np.flatnonzero(np.diff(frames) != 1) + 1
    return ", ".join(f"{run[0]}" if len(run) == 1 else f"{run[0]}-{run[-1]}" for run in np.split(frames, breaks))


def difference(a: Any, b: Any) -> float | None:
    return b - a if numeric(a, b) else None


def _finite_or_none(values: np.ndarray) -> list[float | None]:
    return [float(value) if math.isfinite(value) else None for value in values]


def run_comparison_to_dict(run: RunComparison) -> dict[str, Any]:
    """The comparison as data; with trials, each score also has each side's ``range`` over its trials and
    whether the difference is ``beyond_spread``."""
    both = np.isfinite(run.ate_difference)
    summary = {label: {"a": a, "b": b, "difference": difference(a, b)} for label, (a, b) in run.summary.items()}
    if run.has_trials:
        for label, entry in summary.items():
            range_a, range_b = run.spread.get(label, (None, None))
            entry.update(a_range=range_a, b_range=range_b, beyond_spread=run.beyond_spread(label))
    return {
        "a": run.a.name,
        "b": run.b.name,
        "summary": summary,
        "parameters": None
        if run.parameters is None
        else {key: {"a": a, "b": b} for key, (a, b) in run.parameters.items()},
        "frames_only_a": run.frames_only_a.tolist(),
        "frames_only_b": run.frames_only_b.tolist(),
        "losses_vanished": run.losses_vanished,
        "losses_appeared": run.losses_appeared,
        "ate_difference": {
            "frames": int(both.sum()),
            "mean": float(np.mean(run.ate_difference[both])) if both.any() else None,
            "min": float(np.min(run.ate_difference[both])) if both.any() else None,
            "max": float(np.max(run.ate_difference[both])) if both.any() else None,
        },
        "per_frame": {
            "frame": run.frame_indices.tolist(),
            "ate_a": _finite_or_none(run.ate_a),
            "ate_b": _finite_or_none(run.ate_b),
        },
    }


def comparison_to_dict(comparison: Comparison) -> dict[str, Any]:
    return {
        "a": str(comparison.a.path),
        "b": str(comparison.b.path),
        "sequence": comparison.a.sequence["name"],
        "runs": [run_comparison_to_dict(run) for run in comparison.runs],
    }


def _cell(value: Any, sign: str = "") -> str:
    """Integers as they are, other numbers to the millimetre (or thousandth), missing as a dash."""
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:{sign}.3f}"
    return f"{value:{sign}d}" if isinstance(value, int) and not isinstance(value, bool) else str(value)


def summary_columns(run: RunComparison) -> tuple[str, ...]:
    """The columns of :func:`summary_rows`: with trials, each side's min–max and whether B - A exceeds them."""
    return ("score", "A", "B", "B - A") + (("A min–max", "B min–max", "beyond spread") if run.has_trials else ())


def summary_rows(run: RunComparison) -> list[tuple[str, ...]]:
    """The scores side by side: (score, A, B, B - A) as text; with trials, then the spread columns."""
    rows = []
    for label, (a, b) in run.summary.items():
        row: tuple[str, ...] = (label, _cell(a), _cell(b), _cell(difference(a, b), sign="+"))
        if run.has_trials:
            verdict = run.beyond_spread(label)
            row += (
                *(_range(side) for side in run.spread.get(label, (None, None))),
                "—" if verdict is None else "yes" if verdict else "no",
            )
        rows.append(row)
    return rows


def _range(spread: tuple[float, float] | None) -> str:
    return "—" if spread is None else f"{_cell(spread[0])}–{_cell(spread[1])}"


def _trials_line(run: RunComparison) -> str:
    """What each side's scores are (one run, or the median of how many trials) and which trial the
    frame-by-frame details compare."""
    parts = []
    for side, recorded in (("A", run.a), ("B", run.b)):
        trials = recorded.block.get("trials") or []
        ran = [trial for trial in trials if trial.get("status") == "ok"]
        if not trials:
            parts.append(f"{side} one run")
        elif ran:
            parts.append(
                f"{side} the median of {len(ran)} trials (frame by frame: trial {ran[0]['trial']}, "
                f"seed {ran[0]['seed']})"
            )
        else:
            parts.append(f"{side} no trial that ran")
    return "scores: " + "; ".join(parts) + "; beyond spread: the two sides' min–max ranges do not overlap"


def detail_lines(run: RunComparison) -> list[str]:
    """The ATE difference, the frames only one run tracked, the losses only one had, the parameters that differ;
    with trials first what the scores are."""
    lines = [_trials_line(run)] if run.has_trials else []
    both = np.isfinite(run.ate_difference)
    if both.any():
        lines.append(
            f"ATE difference B - A over {both.sum()} frames both tracked: mean "
            f"{np.mean(run.ate_difference[both]):+.3f} m, from {np.min(run.ate_difference[both]):+.3f} "
            f"to {np.max(run.ate_difference[both]):+.3f} m"
        )
    lines.append(f"frames tracked by B only: {len(run.frames_only_b)} ({frame_ranges(run.frames_only_b)})")
    lines.append(f"frames tracked by A only: {len(run.frames_only_a)} ({frame_ranges(run.frames_only_a)})")
    for title, losses in (("losses in A only", run.losses_vanished), ("losses in B only", run.losses_appeared)):
        lines.append(f"{title}: {len(losses) or 'none'}")
        lines += [
            f"  frame {loss['frame']}: {loss.get('text') or loss['reason']}"
            + ("" if loss["other_tracking"] else " (the other run had no pose there)")
            for loss in losses
        ]
    if run.parameters is None:
        lines.append("parameters: not compared (no parameter in common: different methods)")
    elif run.parameters:
        lines.append("parameters: " + ", ".join(f"{key} {a} -> {b}" for key, (a, b) in run.parameters.items()))
    else:
        lines.append("parameters: the same")
    return lines


def print_comparison(comparison: Comparison, console: Console | None = None) -> None:
    """Per compared run: the scores side by side with B - A, then frames, losses and parameters."""
    console = console or StdoutConsole(markup=False, highlight=False, soft_wrap=True)  # "[m]" is no markup; no wrapping
    console.print(f"A = {comparison.a.path}\nB = {comparison.b.path}\nsequence {comparison.a.sequence['name']}")
    for run in comparison.runs:
        table = Table(title=f"{run.a.name} (A) against {run.b.name} (B)", box=box.SIMPLE_HEAD, pad_edge=False)
        for column in summary_columns(run):
            table.add_column(column, justify="left" if column == "score" else "right", no_wrap=True)
        for row in summary_rows(run):
            table.add_row(*row)
        print_table(table, console)
        for line in detail_lines(run):
            console.print(line)


def markdown_comparison(comparison: ResultsComparison) -> list[str]:
    """The lines of a benchmark report's comparison section: per row both ran, the scores and the details."""
    lines = [f"A = `{comparison.a.folder}`, B = these results; differences are B - A.", ""]
    for sequence, run in comparison.runs:
        columns = summary_columns(run)
        lines += [
            f"### {sequence} / {run.b.name}",
            "",
            "| " + " | ".join(columns) + " |",
            "|---|" + "---:|" * (len(columns) - 1),
        ]
        lines += ["| " + " | ".join(row) + " |" for row in summary_rows(run)]
        lines += [
            "",
            *(
                f"- {line.strip()}" if not line.startswith("  ") else f"  - {line.strip()}"
                for line in detail_lines(run)
            ),
            "",
        ]
    if comparison.not_compared:
        lines += ["Not compared:", ""]
        lines += [f"- {sequence} / {run}: {why}" for sequence, run, why in comparison.not_compared]
        lines.append("")
    if not comparison.runs:
        lines += ["No row ran in both.", ""]
    return lines
