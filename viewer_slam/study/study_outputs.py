"""Write the replayed study: results.json, report.md and the charts, all from the numbers.

The findings are sentences built from the rows (which system ranks first under each score,
where a run stopped, which published figures differ), so the report says what the runs
say, not what was expected of them.
"""

import json
from pathlib import Path
from typing import Any

from ..atomic import StagedFiles
from ..benchmark.plots import plot_all
from ..evaluation.evaluation import RpeMode
from .manifest import COMMIT, REPOSITORY, SYSTEMS
from .replay import Run

TITLES = {system.name: system.title for system in SYSTEMS}


def results(runs: list[Run], found: list[dict], mirror: str) -> dict:
    return {
        "source": {"repository": REPOSITORY, "commit": COMMIT, "fetched_from": mirror},
        "rpe_mode": RpeMode.TUM,
        "rows": [run.to_dict() for run in runs],
        "discrepancies": found,
    }


def chart_rows(runs: list[Run]) -> list[dict]:
    """Rows in the benchmark's chart form; processing time is the published one (no run gives a time)."""
    rows = []
    for run in runs:
        reproduced = run.reproduced
        logged = run.log.get("time_s")
        rows.append(
            {
                "sequence": run.sequence.alias,
                "pipeline": run.system,
                "status": "ok",
                "ate_rmse": reproduced["ate_rmse"],
                "rpe_trans_rmse": reproduced["rpe_trans_rmse"],
                "rpe_rot_rmse": reproduced["rpe_rot_rmse_deg"],
                "time_s": logged.value if logged else None,
                "coverage": reproduced["coverage"],
                "penalized_ate_rmse": reproduced["penalized_ate_rmse"],
            }
        )
    return rows


def _number(value, digits: int = 6) -> str:
    return "—" if value is None else f"{value:.{digits}f}"


def _published(run: Run, figure: str) -> str:
    log, chart = run.log.get(figure), run.chart.get(figure)
    texts = [f"{value.value:.{value.decimals}f}" if value else "—" for value in (log, chart)]
    if log is None or chart is None or log.agrees(chart.value) or chart.agrees(log.value):
        return texts[0] if log is not None else texts[1]
    return f"{texts[0]} / {texts[1]}"


def table(runs: list[Run]) -> str:
    """The study's table, published (log / chart where they differ) beside reproduced, with coverage."""
    lines = [
        "| sequence | system | ATE published | ATE reproduced | RPE trans published | RPE trans reproduced "
        "| RPE rot published [deg] | RPE rot reproduced [deg] | coverage | penalised ATE | stopped at |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for run in runs:
        r = run.reproduced
        stopped = "—" if r["stopped_at_s"] is None else f"{r['stopped_at_s']:.1f} of {r['duration_s']:.1f} s"
        lines.append(
            f"| {run.sequence.alias} | {TITLES[run.system]} | {_published(run, 'ate_rmse')} "
            f"| {_number(r['ate_rmse'])} | {_published(run, 'rpe_trans_rmse')} | {_number(r['rpe_trans_rmse'])} "
            f"| {_published(run, 'rpe_rot_rmse_deg')} | {_number(r['rpe_rot_rmse_deg'])} "
            f"| {r['coverage']:.1%} | {_number(r['penalized_ate_rmse'], 3)} | {stopped} |"
        )
    return "\n".join(lines)


def findings(runs: list[Run], found: list[dict]) -> list[str]:
    """Sentences drawn from the numbers: agreement with the logs, rankings that coverage reverses, stops."""
    sentences = []
    checked = [
        (run, figure)
        for run in runs
        for figure in ("ate_rmse", "rpe_trans_rmse", "rpe_rot_rmse_deg")
        if figure in run.log
    ]
    agreeing = [(run, figure) for run, figure in checked if run.log[figure].agrees(run.reproduced[figure])]
    sentences.append(
        f"{len(agreeing)} of the {len(checked)} ATE and RPE figures of the result logs print exactly "
        f"as their runs give them (RPE as evaluate_rpe.py's default under Python 2.7)."
    )
    by_sequence: dict[str, dict[str, Any]] = {}
    for run in runs:
        by_sequence.setdefault(run.sequence.alias, {})[run.system] = run
    for alias, pair in by_sequence.items():
        if len(pair) != 2:
            continue
        (a, run_a), (b, run_b) = pair.items()
        classic = min(pair, key=lambda name: pair[name].reproduced["ate_rmse"])
        penalised = min(pair, key=lambda name: pair[name].reproduced["penalized_ate_rmse"])
        if classic != penalised:
            loser = pair[classic].reproduced
            sentences.append(
                f"{alias}: classic ATE ranks {TITLES[classic]} first ({loser['ate_rmse']:.3f} m against "
                f"{pair[penalised].reproduced['ate_rmse']:.3f} m), but it has a pose for only "
                f"{loser['coverage']:.1%} of the sequence; penalised ATE ranks {TITLES[penalised]} first "
                f"({pair[penalised].reproduced['penalized_ate_rmse']:.3f} m against "
                f"{loser['penalized_ate_rmse']:.3f} m)."
            )
    for run in runs:
        r = run.reproduced
        if r["stopped_at_s"] is not None and r["coverage"] < 0.9:
            sentences.append(
                f"{run.sequence.alias}: {TITLES[run.system]} produced its last pose "
                f"{r['stopped_at_s']:.1f} s into the {r['duration_s']:.1f} s sequence and none after "
                f"(coverage {r['coverage']:.1%}); its ATE and RPE score only the time before."
            )
    misplaced = [entry for entry in found if entry["kind"] == "misplaced"]
    if misplaced:
        sentences.append(
            f"{len(misplaced)} chart bars print as another sequence's figure of the same system: "
            + "; ".join(entry["text"] for entry in misplaced)
            + "."
        )
    return sentences


def write_report(path: Path, runs: list[Run], found: list[dict], mirror: str, command: str) -> None:
    unverified = sorted({run.sequence.alias for run in runs if not run.verified})
    lines = [
        "# The study replayed from its own runs",
        "",
        f"Runs, groundtruth, result logs and chart scripts of {REPOSITORY} at commit `{COMMIT}`, fetched from "
        f"{mirror}. ATE as TUM's evaluate_ate.py; RPE as evaluate_rpe.py's default under Python 2.7 "
        f"(`--rpe-mode tum`). Coverage and penalised ATE by viewslam's rules. Written by `{command}`.",
        "",
        "Published figures are the result log's, then the chart's after a slash where the two differ.",
        "",
        table(runs),
        "",
        "## Findings",
        "",
    ]
    lines += [f"- {sentence}" for sentence in findings(runs, found)]
    lines += ["", "## Discrepancies", ""]
    lines += [f"- {entry['text']}" for entry in found] or ["- none"]
    if unverified:
        lines += ["", f"Files without a pinned SHA-256 (used unverified): {', '.join(unverified)}."]
    path.write_text("\n".join(lines) + "\n")


def write_all(out: Path, runs: list[Run], found: list[dict], mirror: str, command: str) -> list[Path]:
    """results.json, report.md and the six charts (PNG and SVG), renamed into place together."""
    out.mkdir(parents=True, exist_ok=True)
    written = [out / "results.json", out / "report.md"]
    with StagedFiles() as staged:
        staged.path(written[0]).write_text(json.dumps(results(runs, found, mirror), indent=2) + "\n")
        write_report(staged.path(written[1]), runs, found, mirror, command)
        written += plot_all(chart_rows(runs), out, staged, prefix="study_")
        staged.commit()
    return written
