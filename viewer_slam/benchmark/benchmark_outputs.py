"""The benchmark's outputs: results.csv/json, charts, and report.md with auto-written findings.

The findings make the study's point with numbers: who lost tracking, where, for how long
and whether it came back, and every pair of pipelines that classic ATE ranks one way while
the coverage-aware scores (penalised ATE, coverage) rank or qualify it the other way.
With trials, the table, the charts and the rankings give each pair's median and min–max over
its trials, and where a trajectory or a loss must be shown, its first trial that ran stands
for the pair.
"""

from collections import defaultdict
from functools import partial
from itertools import combinations
from pathlib import Path
from typing import Any

from ..atomic import StagedFiles
from ..comparison.compare import SUMMARY
from ..comparison.output import markdown_comparison
from ..comparison.results import RUNS_FOLDER, BenchmarkResults, compare_results, load_results, runs_report_path
from ..errors import InputError
from ..runs.run_report import versions, write_report
from ..version import __version__
from .plots import CHARTS, plot_all
from .runner import TaskResult, recording_path
from .tables import has_trials, result_row, result_rows, write_csv, write_json
from .trials import summarise_pairs, with_spread

# Coverages closer than this (one percentage point) count as equal when ranking.
COVERAGE_TIE = 0.01


OUTPUT_FILES = ("results.csv", "results.json", "report.md")
RECORDINGS_FOLDER = "recordings"


def write_outputs(
    results: list[TaskResult], out_dir: Path, compare_with: BenchmarkResults | None = None, recorded: bool = False
) -> list[Path]:
    """Write every output into ``out_dir`` (each file renamed into place once complete); returns them all.

    Files an earlier benchmark wrote there that these results do not list are removed: run
    reports, trajectories, charts, and recordings (``OUT/recordings``, kept only for the rows
    of a benchmark that ``recorded``), so nothing stale sits beside the new results.

    With ``compare_with`` (another results folder), report.md also compares every row both
    have, as `viewslam diff` does; the rows are read back from ``out_dir/runs``, exactly as
    a later comparison against this folder would read them.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = result_rows(results)
    csv_path, json_path, report_path = (out_dir / name for name in OUTPUT_FILES)
    try:
        with StagedFiles() as staged:
            runs = write_runs(results, out_dir, staged)
            write_csv(staged.path(csv_path), rows)
            write_json(staged.path(json_path), rows)
            staged.path(report_path).write_text(markdown_report(results))
            charts = plot_all(summarise_pairs(rows) if has_trials(results) else rows, out_dir, staged)
            staged.commit()
        recordings = _recordings(results, out_dir) if recorded else []
        for path in set(_earlier_outputs(out_dir)) - {*runs, *charts, *recordings}:
            path.unlink(missing_ok=True)  # an earlier run's, which the results now in place do not list
        if compare_with is not None:  # a comparison refused (an InputError) leaves the report without it
            comparison = markdown_comparison(compare_results(compare_with, load_results(out_dir)))
            with StagedFiles() as staged:
                staged.path(report_path).write_text(markdown_report(results, comparison=comparison))
                staged.commit()
    except OSError as error:
        raise InputError.at(out_dir, f"cannot write the results: {error.strerror or error}") from None
    return [csv_path, json_path, report_path, *runs, *charts]


def planned_outputs(out_dir: Path, tasks) -> dict[Path, str]:
    """Every file the benchmark of ``tasks`` (BenchmarkTask) may write into ``out_dir``, each
    named by the option that chose it (``--out``)."""
    paths = [*(out_dir / name for name in OUTPUT_FILES), *_chart_paths(out_dir)]
    for task in tasks:
        report = runs_report_path(out_dir, task.name)
        paths += [report, report.with_name(f"{report.stem}.{task.pipeline}.txt")]
    return dict.fromkeys(paths, "--out")


def _earlier_outputs(out_dir: Path) -> list[Path]:
    """The run reports, trajectories, charts and recordings a benchmark may have written into ``out_dir``."""
    written = [
        path
        for folder in (RUNS_FOLDER, RECORDINGS_FOLDER)
        for kind in ("json", "txt", "rrd")
        for path in (out_dir / folder).glob(f"*.{kind}")
    ]
    return [path for path in (*_chart_paths(out_dir), *written) if path.is_file()]


def _recordings(results: list[TaskResult], out_dir: Path) -> list[Path]:
    """Each row's recording in ``OUT/recordings`` with the report and trajectory `viewslam record` wrote beside it."""
    paths = []
    for result in results:
        recording = recording_path(out_dir / RECORDINGS_FOLDER, result.sequence, result.pipeline, result.trial)
        paths += [recording, recording.with_suffix(".json"), recording.with_suffix(f".{result.pipeline}.txt")]
    return paths


def _chart_paths(out_dir: Path) -> list[Path]:
    return [out_dir / f"benchmark_{metric}.{kind}" for metric in CHARTS for kind in ("png", "svg")]


def write_runs(results: list[TaskResult], out_dir: Path, staged: StagedFiles) -> list[Path]:
    """Per sequence, a report in `viewslam record`'s form and each run's trajectory beside it, in ``OUT/runs``.

    A pair run as several trials is represented by its first trial that ran, whose block also
    lists every trial's scores under ``trials`` (see :func:`trial_entry`).
    """
    (out_dir / RUNS_FOLDER).mkdir(exist_ok=True)
    trials = pair_trials(results)
    by_sequence = defaultdict(list)
    for result in representatives(results):
        by_sequence[result.sequence].append(result)
    written = []
    for sequence, group in by_sequence.items():
        path = runs_report_path(out_dir, sequence)
        blocks = {result.pipeline: _run_block(result, trials[sequence, result.pipeline]) for result in group}
        report = {
            "sequence": group[0].sequence_block,
            "interrupted": False,
            "versions": versions(),
            "pipelines": blocks,
        }
        write_report(staged.path(path), report)
        written.append(path)
        for result in group:
            trajectory = path.with_name(f"{path.stem}.{result.pipeline}.txt")
            assert result.trajectory is not None  # an ok result carries its run's trajectory
            staged.path(trajectory).write_text(result.trajectory)
            written.append(trajectory)
    return written


def pair_trials(results: list[TaskResult]) -> dict[tuple[str, str], list[TaskResult]]:
    """The results of each (sequence, run) pair, in trial order."""
    pairs: dict[tuple[str, str], list[TaskResult]] = {}
    for result in results:
        pairs.setdefault((result.sequence, result.pipeline), []).append(result)
    return pairs


def representatives(results: list[TaskResult]) -> list[TaskResult]:
    """Each pair's first result that ran (its only one, without trials), in order."""
    return [
        next(result for result in group if result.ok)
        for group in pair_trials(results).values()
        if any(result.ok for result in group)
    ]


def _run_block(result: TaskResult, trials: list[TaskResult]) -> dict:
    """The report block of a pair's ``result``, with every trial's scores when the pair ran as trials."""
    assert result.report is not None  # an ok result carries its report
    if result.trial is None:
        return result.report
    return {**result.report, "trials": [trial_entry(trial) for trial in trials]}


def trial_entry(result: TaskResult) -> dict:
    """One trial's scores in a run block's ``trials`` list: its trial, seed and status, and the
    scores a comparison reads, at the places they have in the block itself."""
    entry: dict = {"trial": result.trial, "seed": result.seed, "status": result.status}
    if result.report is None:
        return entry
    for _, keys in SUMMARY:
        value: Any = result.report
        for key in keys:
            value = value.get(key) if isinstance(value, dict) else None
        place: dict = entry
        for key in keys[:-1]:
            place = place.setdefault(key, {})
        place[keys[-1]] = value
    return entry


def markdown_report(
    results: list[TaskResult], chart_prefix: str = "benchmark_", comparison: list[str] | None = None
) -> str:
    """The report; ``comparison`` is the body of its comparison section (see :func:`write_outputs`)."""
    pipelines = ", ".join(dict.fromkeys(result.pipeline for result in results))
    sequences = len(dict.fromkeys(result.sequence for result in results))
    failed = [result for result in results if not result.ok]
    lines = [
        "# Benchmark results",
        "",
        f"{sequences} sequence{'s' if sequences != 1 else ''} x pipelines {pipelines}; viewslam {__version__}. "
        "ATE and RPE follow Sturm et al. (RPE over 1 s); coverage is the share of the sequence's time with a pose, and the penalised ATE charges "
        "that lost time with the error of the last pose held.",
        "",
        "## Results",
        "",
        *(trials_table(results) if has_trials(results) else [results_table(results)]),
        "",
    ]
    if failed:
        lines += ["## Failed tasks", ""]
        lines += [
            f"- {result.sequence} / {result.pipeline}"
            f"{'' if result.trial is None else f' trial {result.trial} (seed {result.seed})'}: {result.error}"
            for result in failed
        ]
        lines.append("")
    lines += ["## Findings", ""]
    lines += [f"- {finding}" for finding in findings(results)]
    if comparison is not None:
        lines += ["", "## Compared with other results", "", *comparison]
    lines += ["", "## Charts", ""]
    lines += [f"![{title}]({chart_prefix}{metric}.png)" for metric, title in CHARTS.items()]
    return "\n".join(lines) + "\n"


def _number(value, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def results_table(results: list[TaskResult]) -> str:
    """The study's columns (ATE, RPE, time) followed by the coverage-aware ones."""
    header = (
        "| Sequence | Pipeline | ATE RMSE [m] | RPE trans RMSE [m] | RPE rot RMSE [deg] | Time [s] | FPS "
        "| Coverage | Penalised ATE RMSE [m] | Poses / frames | Loop closures | Status |"
    )
    lines = [header, "|" + "---|" * header.count(" | ") + "---|"]
    for result in results:
        row = result_row(result)
        coverage = "-" if row["coverage"] is None else f"{100 * row['coverage']:.1f} %"
        poses = "-" if row["frames"] is None else f"{row['frames_with_pose']} / {row['frames']}"
        cells = (
            row["sequence"],
            row["pipeline"],
            _number(row["ate_rmse"], 3),
            _number(row["rpe_trans_rmse"], 3),
            _number(row["rpe_rot_rmse"], 2),
            _number(row["time_s"], 1),
            _number(row["fps"], 1),
            coverage,
            _number(row["penalized_ate_rmse"], 3),
            poses,
            _number(row["loop_closures"], 0),
            row["status"],
        )
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def trials_table(results: list[TaskResult]) -> list[str]:
    """The pairs' medians and min–max over their trials, with the line that says how to read them."""
    seeds = sorted({result.seed for result in results if result.trial is not None and result.seed is not None})
    header = (
        "| Sequence | Pipeline | Trials | ATE RMSE [m] | RPE trans RMSE [m] | RPE rot RMSE [deg] | Time [s] "
        "| Coverage | Penalised ATE RMSE [m] | Poses | Loop closures | Status |"
    )
    lines = [
        f"Each cell is the median over the pair's trials and, in brackets, their min–max; the trials ran "
        f"with seeds {seeds[0]} to {seeds[-1]}. A pair with one trial (an imported estimate) shows its "
        f"one value.",
        "",
        header,
        "|" + "---|" * header.count(" | ") + "---|",
    ]
    for summary in summarise_pairs(result_rows(results)):
        cells = [summary["sequence"], summary["pipeline"], str(summary["trials"])]
        cells += [with_spread(summary, score, partial(_score_text, score)) for score in _TRIAL_DIGITS]
        cells.append(summary["status"])
        lines.append("| " + " | ".join(cells) + " |")
    return lines


_TRIAL_DIGITS = {
    "ate_rmse": 3,
    "rpe_trans_rmse": 3,
    "rpe_rot_rmse": 2,
    "time_s": 1,
    "coverage": 1,
    "penalized_ate_rmse": 3,
    "frames_with_pose": 0,
    "loop_closures": 0,
}
"""The trials table's scores, in its order, with the decimals each is written with."""


def _score_text(score: str, value: float) -> str:
    return f"{100 * value:.1f} %" if score == "coverage" else _number(value, _TRIAL_DIGITS[score])


def findings(results: list[TaskResult]) -> list[str]:
    """Losses and rankings from the numbers; with trials, each pair's losses are its first trial's
    and its rankings are of the medians over its trials."""
    ok = representatives(results)
    found = [line for result in ok if (text := tracking_finding(result)) for line in (text, *cause_findings(result))]
    if has_trials(results):
        found += [text for group in pair_trials(results).values() if (text := trials_finding(group))]
    if not found and any(result_row(result)["coverage"] is not None for result in ok):
        found.append("No pipeline lost tracking on any sequence.")
    rows = summarise_pairs(result_rows(results)) if has_trials(results) else [result_row(result) for result in ok]
    by_sequence = defaultdict(list)
    for row in rows:
        if row["status"] != "failed":
            by_sequence[row["sequence"]].append(row)
    for sequence, group in by_sequence.items():
        for first, second in combinations(group, 2):
            if text := ranking_finding(sequence, first, second):
                found.append(text)
    return found


def trials_finding(group: list[TaskResult]) -> str | None:
    """In how many of a pair's trials the run lost tracking, and its coverage's range, when it lost in any."""
    ran = [result for result in group if result.ok]
    lost = [result for result in ran if (row := result_row(result))["lost_intervals"] or not row["frames_with_pose"]]
    if len(group) < 2 or not lost:
        return None
    coverages = [value for result in ran if (value := result_row(result)["coverage"]) is not None]
    spread = f" (coverage {100 * min(coverages):.1f} to {100 * max(coverages):.1f} %)" if coverages else ""
    return (
        f"**{group[0].pipeline}** on *{group[0].sequence}* lost tracking in {len(lost)} of its {len(ran)} "
        f"trials that ran{spread}."
    )


def tracking_finding(result: TaskResult) -> str | None:
    """Where ``result``'s pipeline had no pose, for how long, and whether it came back."""
    row = result_row(result)
    assert result.time_span is not None  # an ok result carries its time span
    start, end = result.time_span
    who = f"**{result.pipeline}** on *{result.sequence}*"
    if result.trial is not None:
        who += f" (trial {result.trial}, seed {result.seed})"
    if not row["frames_with_pose"]:
        return f"{who} produced no pose at all."
    intervals = row["lost_intervals"] or []
    if not intervals:
        return None
    assert result.report is not None  # an ok result carries its report
    events = result.report.get("tracking_lost") or []
    parts = []
    for lost_from, lost_to in intervals:
        reasons = [event["reason"] for event in events if lost_from <= event["timestamp"] <= lost_to]
        outcome = "never recovered" if lost_to >= end else f"recovered at {lost_to - start:.1f} s"
        because = f" [{reasons[0]}]" if reasons else ""
        parts.append(f"at {lost_from - start:.1f} s for {lost_to - lost_from:.1f} s{because}, {outcome}")
    total = sum(lost_to - lost_from for lost_from, lost_to in intervals)
    return (
        f"{who} lost tracking {len(intervals)} time{'s' if len(intervals) > 1 else ''} "
        f"({total:.1f} s of {end - start:.1f} s; coverage {100 * row['coverage']:.1f} %): " + "; ".join(parts) + "."
    )


def cause_findings(result: TaskResult) -> list[str]:
    """The diagnosed cause of each of ``result``'s losses, one line each."""
    report = result.report
    assert report is not None  # an ok result carries its report
    return [f"*{result.sequence}*: {event['text']}" for event in report.get("tracking_lost") or [] if "text" in event]


def ranking_finding(sequence: str, a: dict, b: dict) -> str | None:
    """The classic-ATE order of two pipelines' rows on one sequence, when coverage-aware scores disagree."""
    if a["ate_rmse"] is None and b["ate_rmse"] is None:
        return None
    if a["ate_rmse"] is None or b["ate_rmse"] is None:
        scored, unscored = (a, b) if b["ate_rmse"] is None else (b, a)
        return (
            f"On *{sequence}*, classic ATE has no score for {unscored['pipeline']} (no pose) and so cannot rank "
            f"it against {scored['pipeline']} (ATE {scored['ate_rmse']:.3f} m)."
        )
    better, worse = (a, b) if a["ate_rmse"] <= b["ate_rmse"] else (b, a)
    penalised_flips = (
        better["penalized_ate_rmse"] is not None
        and worse["penalized_ate_rmse"] is not None
        and better["penalized_ate_rmse"] > worse["penalized_ate_rmse"]
    )
    covers_less = better["coverage"] < worse["coverage"] - COVERAGE_TIE
    if not (penalised_flips or covers_less):
        return None
    text = (
        f"On *{sequence}*, classic ATE ranks {better['pipeline']} ahead of {worse['pipeline']} "
        f"({better['ate_rmse']:.3f} m vs {worse['ate_rmse']:.3f} m)"
    )
    if covers_less:
        text += (
            f", although {better['pipeline']} has a pose for {100 * better['coverage']:.1f} % of the time "
            f"and {worse['pipeline']} for {100 * worse['coverage']:.1f} %"
        )
    verdict = "reverses" if penalised_flips else "keeps"
    text += (
        f"; penalised ATE {verdict} the order ({better['penalized_ate_rmse']:.3f} m vs "
        f"{worse['penalized_ate_rmse']:.3f} m)."
    )
    return text
