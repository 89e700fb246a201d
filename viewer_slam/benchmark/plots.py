"""The benchmark's and the study's charts: one grouped bar chart per metric, sequences along x,
a bar per pipeline; with trials, each bar is the median and a whisker spans the trials' min–max.

The first four are the study's (ATE, RPE translation, RPE rotation, processing time); the
last two are the coverage-aware scores. A chart must read at any scale: where the values
span more than two decades (0.002 m beside 1.9 m) the axis is logarithmic, or the small
bars would be invisible; every bar carries its value; the figure is cropped to what is
drawn. Files are reproducible: SVG ids are salted with a constant and no creation date is
written.
"""

import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the headless backend)
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import FuncFormatter, NullFormatter, PercentFormatter  # noqa: E402

from .. import palette  # noqa: E402
from ..atomic import StagedFiles  # noqa: E402

CHARTS = {
    "ate_rmse": "ATE RMSE [m]",
    "rpe_trans_rmse": "RPE translational RMSE [m]",
    "rpe_rot_rmse": "RPE rotational RMSE [deg]",
    "time_s": "Processing time [s]",
    "coverage": "Coverage (share of time with a pose)",
    "penalized_ate_rmse": "Penalised ATE RMSE [m]",
}
SHARES = {"coverage"}  # 0 to 1, drawn as percentages on a linear axis
LOG_SPAN = 100.0  # largest / smallest positive value above which the axis is logarithmic
PAD_INCHES = 0.05  # the margin left around what is drawn


def uses_log_axis(values: list[float | None]) -> bool:
    """Whether the positive values span more than two decades."""
    positive = [value for value in values if value is not None and value > 0 and math.isfinite(value)]
    return len(positive) > 1 and max(positive) / min(positive) > LOG_SPAN


def number_text(value: float) -> str:
    """Three significant digits, never in exponent form: 0.003, 0.0212, 1.94, 326."""
    return np.format_float_positional(value, precision=3, unique=False, fractional=False, trim="-")


def value_text(metric: str, value: float) -> str:
    """A bar's value as printed over it, a percentage for a share."""
    return f"{value:.0%}" if metric in SHARES else number_text(value)


def draw_metric(rows: list[dict[str, Any]], metric: str) -> Figure:
    """The chart of ``metric`` for every row (the caller closes it).

    A failed task is marked "failed" and a run without the score (no pose) "n/a" where its
    bar would be. A row with a ``spread`` of the metric (a pair's trials: ``(min, max)`` around
    the median the row holds) gets a whisker from its min to its max.
    """
    sequences = list(dict.fromkeys(row["sequence"] for row in rows))
    pipelines = list(dict.fromkeys(row["pipeline"] for row in rows))
    by_pair = {(row["sequence"], row["pipeline"]): row for row in rows}
    width = 0.8 / len(pipelines)
    centres = np.arange(len(sequences))
    values = [row.get(metric) for row in rows] + [end for row in rows for end in row.get("spread", {}).get(metric, ())]
    log = metric not in SHARES and uses_log_axis(values)
    figure, axes = plt.subplots(figsize=(max(6.0, 1.2 * len(sequences) + 2), 4.2), layout="constrained")
    if log:
        axes.set_yscale("log")
        axes.yaxis.set_major_formatter(FuncFormatter(lambda value, _: number_text(value)))
        axes.yaxis.set_minor_formatter(NullFormatter())
    elif metric in SHARES:
        axes.yaxis.set_major_formatter(PercentFormatter(1.0, decimals=0))
    for k, pipeline in enumerate(pipelines):
        offsets = centres + (k - (len(pipelines) - 1) / 2) * width
        scores = [by_pair.get((sequence, pipeline), {}).get(metric) for sequence in sequences]
        heights = [np.nan if value is None else value for value in scores]
        bars = axes.bar(
            offsets,
            heights,
            width,
            label=pipeline,
            color=palette.run_colour(pipeline, k).hex,
            **_whiskers(metric, [by_pair.get((sequence, pipeline), {}) for sequence in sequences]),
        )
        axes.bar_label(
            bars, [value_text(metric, value) if value is not None else "" for value in scores], fontsize=7, padding=1
        )
        for x, sequence, value in zip(offsets, sequences, scores):
            row = by_pair.get((sequence, pipeline))
            if row is not None and value is None:
                axes.text(
                    x,
                    0.02,
                    "failed" if row["status"] != "ok" else "n/a",
                    rotation=90,
                    ha="center",
                    va="bottom",
                    fontsize=7,
                    color="0.35",
                    transform=axes.get_xaxis_transform(),
                )
    _fit_values(axes, values, log)
    axes.set_xticks(centres, sequences, rotation=25, ha="right")
    axes.set_xlim(-0.6, len(sequences) - 0.4)  # missing bars must not shrink the axis
    axes.set_ylabel(CHARTS[metric] + (", log scale" if log else ""))
    spread = any(metric in row.get("spread", {}) for row in rows)
    axes.set_title(
        CHARTS[metric] + ("\nmedian, whiskers min–max over the trials" if spread else ""), fontsize=10, loc="left"
    )  # the legend sits on the right
    axes.grid(axis="y", which="major", alpha=0.3)
    axes.legend(ncols=len(pipelines), loc="lower right", bbox_to_anchor=(1.0, 1.0), frameon=False, borderaxespad=0.2)
    return figure


def _whiskers(metric: str, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The bars' error-bar options spanning each row's min–max of ``metric``; none when no row has a spread."""
    spreads = [row.get("spread", {}).get(metric) for row in rows]
    if not any(spreads):
        return {}
    below = [row[metric] - spread[0] if spread else 0.0 for row, spread in zip(rows, spreads)]
    above = [spread[1] - row[metric] if spread else 0.0 for row, spread in zip(rows, spreads)]
    return {"yerr": [below, above], "capsize": 2.5, "error_kw": {"elinewidth": 0.9, "ecolor": "0.2"}}


def _fit_values(axes, values: list[float | None], log: bool) -> None:
    """Limits with room above the tallest bar for its value; on a log axis, whole decades."""
    known = [value for value in values if value is not None and math.isfinite(value)]
    if not known:
        return
    if log:
        positive = [value for value in known if value > 0]
        axes.set_ylim(10 ** math.floor(math.log10(min(positive))), 10 ** (math.log10(max(positive)) + 0.35))
    else:
        axes.set_ylim(min(0.0, min(known)), max(max(known), 1e-12) * 1.12)


def plot_metric(
    rows: list[dict[str, Any]],
    metric: str,
    out_dir: Path,
    prefix: str = "benchmark_",
    staged: StagedFiles | None = None,
) -> list[Path]:
    """Draw ``metric`` for every row into ``<prefix><metric>.png`` and ``.svg``; returns both paths.

    With ``staged``, each file is written to its temporary stand-in, renamed into place at the
    commit with the other outputs.
    """
    with plt.rc_context({"svg.hashsalt": "viewslam", "font.size": 9}):
        figure = draw_metric(rows, metric)
        paths = [out_dir / f"{prefix}{metric}.png", out_dir / f"{prefix}{metric}.svg"]
        where = staged.path if staged is not None else Path
        figure.savefig(
            where(paths[0]),
            format="png",
            dpi=120,
            metadata={"Software": None},
            bbox_inches="tight",
            pad_inches=PAD_INCHES,
        )
        figure.savefig(
            where(paths[1]),
            format="svg",
            metadata={"Date": None, "Creator": None},
            bbox_inches="tight",
            pad_inches=PAD_INCHES,
        )
        plt.close(figure)
    return paths


def plot_all(rows: list[dict[str, Any]], out_dir: Path, staged: StagedFiles, prefix: str = "benchmark_") -> list[Path]:
    """Every chart of :data:`CHARTS`, PNG and SVG."""
    return [path for metric in CHARTS for path in plot_metric(rows, metric, out_dir, prefix, staged)]
