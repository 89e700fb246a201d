"""The results table: one row per (sequence, pipeline) and trial, written as CSV and JSON."""

import csv
import json
from functools import partial
from pathlib import Path
from typing import Any

from .runner import TaskResult
from .trials import summarise_pairs, with_spread

COLUMNS = (
    "sequence",
    "pipeline",
    "ate_rmse",
    "rpe_trans_rmse",
    "rpe_rot_rmse",
    "time_s",
    "fps",
    "coverage",
    "penalized_ate_rmse",
    "frames",
    "frames_with_pose",
    "loop_closures",
    "lost_intervals",
    "status",
)
TRIAL_COLUMNS = (*COLUMNS[:2], "trial", "seed", *COLUMNS[2:])
"""The columns when some pair ran as several trials: each row also names its trial and seed."""


def _lookup(block: dict | None, *keys: str) -> Any:
    """``block[k1][k2]...`` or None where a level is missing or null (no pose, no pairs)."""
    for key in keys:
        if not isinstance(block, dict):
            return None
        block = block.get(key)
    return block


def result_row(result: TaskResult) -> dict[str, Any]:
    """The table row of one result; metrics are None for a failed task or a missing score.

    ``rpe_rot_rmse`` is in degrees, lengths in metres, ``lost_intervals`` are
    ``[start, end]`` pairs of dataset timestamps. An imported estimate has no timing of its own.
    """
    report = result.report
    timed = _lookup(report, "source") != "estimate"
    return {
        "sequence": result.sequence,
        "pipeline": result.pipeline,
        "ate_rmse": _lookup(report, "ate", "rmse"),
        "rpe_trans_rmse": _lookup(report, "rpe", "trans", "rmse"),
        "rpe_rot_rmse": _lookup(report, "rpe", "rot", "rmse"),
        "time_s": _lookup(report, "timing", "total_s") if timed else None,
        "fps": _lookup(report, "timing", "fps") if timed else None,
        "coverage": _lookup(report, "coverage", "ratio"),
        "penalized_ate_rmse": _lookup(report, "penalized_ate", "rmse"),
        "frames": result.frames if result.ok else None,
        "frames_with_pose": _lookup(report, "frames_with_pose"),
        "loop_closures": _lookup(report, "loop_closures", "accepted"),
        "lost_intervals": _lookup(report, "coverage", "lost_intervals"),
        "status": result.status,
    }


def has_trials(results: list[TaskResult]) -> bool:
    """Whether some pair of ``results`` ran as several trials."""
    return any(result.trial is not None for result in results)


def result_rows(results: list[TaskResult]) -> list[dict[str, Any]]:
    """The table's rows, one per result; with trials, each row's ``trial`` (from 0; null for a pair that
    ran once, an estimate) and ``seed`` (null for an estimate) follow its pipeline."""
    rows = [result_row(result) for result in results]
    if not has_trials(results):
        return rows
    return [
        {
            **{key: row[key] for key in COLUMNS[:2]},
            "trial": result.trial,
            "seed": result.seed,
            **{key: row[key] for key in COLUMNS[2:]},
        }
        for row, result in zip(rows, results)
    ]


def write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    """Empty cells for missing values; ``lost_intervals`` as JSON text."""
    columns = TRIAL_COLUMNS if any("trial" in row for row in rows) else COLUMNS
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            cells = {key: "" if value is None else value for key, value in row.items()}
            if row["lost_intervals"] is not None:
                cells["lost_intervals"] = json.dumps(row["lost_intervals"])
            writer.writerow(cells)


def write_json(path: Path, rows: list[dict[str, Any]]) -> None:
    Path(path).write_text(json.dumps(rows, indent=2) + "\n")


def print_results(results: list[TaskResult]) -> None:
    """The results table on stdout: the headline scores of every task, full numbers; with trials, of
    every pair, as the median and the min–max over its trials."""
    from ..terminal import print_table

    print_table(_trials_table(results) if has_trials(results) else _results_table(results))


def _results_table(results: list[TaskResult]):
    from rich import box
    from rich.table import Table

    table = Table(box=box.SIMPLE_HEAD, pad_edge=False, caption="RMSE in m, RPE rot in deg; RPE over 1 s")
    headers = {
        "sequence": "sequence",
        "pipeline": "pipeline",
        "ate_rmse": "ATE",
        "penalized_ate_rmse": "penal. ATE",
        "rpe_trans_rmse": "RPE trans",
        "rpe_rot_rmse": "RPE rot",
        "coverage": "coverage",
        "frames_with_pose": "poses",
        "frames": "frames",
        "fps": "fps",
        "status": "status",
    }
    for key, title in headers.items():
        table.add_column(title, justify="left" if key in ("sequence", "pipeline", "status") else "right", no_wrap=True)
    for result in results:
        row = result_row(result)
        table.add_row(*(_cell(key, row[key]) for key in headers))
    return table


def _trials_table(results: list[TaskResult]):
    from rich import box
    from rich.table import Table

    table = Table(
        box=box.SIMPLE_HEAD,
        pad_edge=False,
        caption="median (min–max) over the trials; RMSE in m, RPE rot in deg, time in s; RPE over 1 s",
    )
    headers = {
        "sequence": "sequence",
        "pipeline": "pipeline",
        "trials": "trials",
        "ate_rmse": "ATE",
        "penalized_ate_rmse": "penal. ATE",
        "rpe_trans_rmse": "RPE trans",
        "rpe_rot_rmse": "RPE rot",
        "coverage": "coverage",
        "time_s": "time",
        "status": "status",
    }
    for key, title in headers.items():
        table.add_column(title, justify="left" if key in ("sequence", "pipeline", "status") else "right", no_wrap=True)
    for summary in summarise_pairs(result_rows(results)):
        table.add_row(
            *(
                str(summary[key])
                if key in ("sequence", "pipeline", "trials", "status")
                else with_spread(summary, key, partial(_cell, key))
                for key in headers
            )
        )
    return table


def _cell(key: str, value: Any) -> str:
    if value is None:
        return "-"
    if key == "coverage":
        return f"{value:.1%}"
    if key in ("fps", "time_s"):
        return f"{value:.1f}"
    return f"{value:.4f}" if isinstance(value, float) else str(value)
