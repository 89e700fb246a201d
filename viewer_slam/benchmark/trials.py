"""A pair's trials summarised: the median of each score and its min–max over the trials that scored.

A pair (sequence, run) runs once per trial, each trial with its own seed, so a score is a
sample of a spread rather than one number. The median says where the trials sit, the
min–max how far one draw can land from it; both are reported because with a handful of
trials neither a mean nor a standard deviation means much. A pair that runs once (an
estimate, or a benchmark without trials) is summarised as itself, with no spread.
"""

import statistics
from collections.abc import Callable
from typing import Any

SPREAD_SCORES = (
    "ate_rmse",
    "rpe_trans_rmse",
    "rpe_rot_rmse",
    "time_s",
    "fps",
    "coverage",
    "penalized_ate_rmse",
    "frames_with_pose",
    "loop_closures",
)
"""The scores of a results row that are summarised over trials."""


def pair_status(statuses: list[str]) -> str:
    """``ok`` when every trial ran, ``failed`` when none did, else how many of them ran."""
    ok = statuses.count("ok")
    return "ok" if ok == len(statuses) else "failed" if ok == 0 else f"{ok} of {len(statuses)} ok"


def summarise_pairs(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (sequence, pipeline), in the order pairs first appear: each score's median over the
    trials that have it, its ``(min, max)`` under ``spread`` when more than one has it, ``trials`` the
    number of trials and ``status`` as :func:`pair_status` says."""
    pairs: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in rows:
        pairs.setdefault((row["sequence"], row["pipeline"]), []).append(row)
    summaries = []
    for (sequence, pipeline), trials in pairs.items():
        scored = [row for row in trials if row["status"] == "ok"]
        summary: dict[str, Any] = {
            "sequence": sequence,
            "pipeline": pipeline,
            "trials": len(trials),
            "frames": scored[0]["frames"] if scored else None,
            "status": pair_status([row["status"] for row in trials]),
            "spread": {},
        }
        for score in SPREAD_SCORES:
            values = [row[score] for row in scored if row[score] is not None]
            summary[score] = statistics.median(values) if values else None
            if len(values) > 1:
                summary["spread"][score] = (min(values), max(values))
        summaries.append(summary)
    return summaries


def with_spread(summary: dict[str, Any], score: str, text: Callable[[Any], str]) -> str:
    """A summary's score as ``median (min–max)``, each written by ``text``; the median alone without a spread."""
    value = summary[score]
    if value is None:
        return "-"
    spread = summary["spread"].get(score)
    return text(value) if spread is None else f"{text(value)} ({text(spread[0])}–{text(spread[1])})"
