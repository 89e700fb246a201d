"""The study's charts: one grouped bar chart per metric, sequences along x, a bar per pipeline.

The first four are the study's (ATE, RPE translation, RPE rotation, processing time); the
last two are the coverage-aware scores. Files are reproducible: SVG ids are salted with a
constant and no creation date is written.
"""

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after choosing the headless backend)
import numpy as np  # noqa: E402

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


def plot_metric(rows: list[dict[str, Any]], metric: str, out_dir: Path, prefix: str = "benchmark_",
                staged: StagedFiles | None = None) -> list[Path]:
    """Draw ``metric`` for every row into ``<prefix><metric>.png`` and ``.svg``; returns both paths.

    With ``staged``, each file is written to its temporary stand-in, renamed into place at the
    commit with the other outputs.

    A failed task is marked "failed" and a run without the score (no pose) "n/a" where its
    bar would be.
    """
    sequences = list(dict.fromkeys(row["sequence"] for row in rows))
    pipelines = list(dict.fromkeys(row["pipeline"] for row in rows))
    by_pair = {(row["sequence"], row["pipeline"]): row for row in rows}
    width = 0.8 / len(pipelines)
    centres = np.arange(len(sequences))
    with plt.rc_context({"svg.hashsalt": "viewslam", "font.size": 9}):
        # Fixed margins (room for slanted sequence names) instead of a layout engine: one draw per file.
        figure, axes = plt.subplots(figsize=(max(6.0, 1.2 * len(sequences) + 2), 4.8))
        figure.subplots_adjust(left=0.09, right=0.98, top=0.84, bottom=0.32)
        for k, pipeline in enumerate(pipelines):
            offsets = centres + (k - (len(pipelines) - 1) / 2) * width
            values = [by_pair.get((sequence, pipeline), {}).get(metric) for sequence in sequences]
            heights = [np.nan if value is None else value for value in values]
            axes.bar(offsets, heights, width, label=pipeline, color=palette.run_colour(pipeline, k).hex)
            for x, sequence, value in zip(offsets, sequences, values):
                row = by_pair.get((sequence, pipeline))
                if row is not None and value is None:
                    axes.text(x, 0, "failed" if row["status"] != "ok" else "n/a", rotation=90,
                              ha="center", va="bottom", fontsize=7, color="0.35")
        axes.set_xticks(centres, sequences, rotation=25, ha="right")
        axes.set_xlim(-0.6, len(sequences) - 0.4)  # missing bars must not shrink the axis
        axes.set_ylabel(CHARTS[metric])
        figure.suptitle(CHARTS[metric])
        axes.grid(axis="y", alpha=0.3)
        axes.legend(ncols=len(pipelines), loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
        paths = [out_dir / f"{prefix}{metric}.png", out_dir / f"{prefix}{metric}.svg"]
        where = staged.path if staged is not None else Path
        figure.savefig(where(paths[0]), format="png", dpi=120, metadata={"Software": None})
        figure.savefig(where(paths[1]), format="svg", metadata={"Date": None, "Creator": None})
        plt.close(figure)
    return paths


def plot_all(rows: list[dict[str, Any]], out_dir: Path, staged: StagedFiles, prefix: str = "benchmark_") -> list[Path]:
    return [path for metric in CHARTS for path in plot_metric(rows, metric, out_dir, prefix, staged)]
