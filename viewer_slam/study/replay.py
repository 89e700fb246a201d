"""Replay the study from its own runs: every published figure beside what its run gives, and what differs.

Each run is scored as the study scored it — ATE as TUM's evaluate_ate.py computes it,
RPE as evaluate_rpe.py's default under Python 2.7 (:mod:`viewer_slam.evaluation.tum_rpe`)
— and with the coverage-aware scores the study could only describe. A published figure
that does not print as its run's figure at its own decimals is a discrepancy; a chart bar
that prints as another sequence's figure is one placed under another sequence's label.
"""

from dataclasses import dataclass
from pathlib import Path

from ..evaluation.evaluation import RpeMode
from ..geometry.trajectory_formats import TrajectoryFormat
from ..runs.trajectory_files import ScoringOptions, read_estimate_file, read_groundtruth, score_estimate
from .manifest import CHARTS, SEQUENCES, SYSTEMS, StudySequence, groundtruth_path, log_path, poses_path
from .published import Printed, parse_chart, parse_log

FIGURES = ("ate_rmse", "rpe_trans_rmse", "rpe_rot_rmse_deg")
STUDY_SCORING = ScoringOptions(rpe_mode=RpeMode.TUM)  # RPE as the study's evaluate_rpe.py ran
FIGURE_NAMES = {
    "ate_rmse": "ATE RMSE",
    "rpe_trans_rmse": "RPE translation RMSE",
    "rpe_rot_rmse_deg": "RPE rotation RMSE",
    "time_s": "processing time",
}


@dataclass
class Run:
    """One sequence × system: the run scored, and what the study printed for it."""

    sequence: StudySequence
    system: str
    reproduced: dict
    log: dict[str, Printed]
    chart: dict[str, Printed]
    verified: bool

    def to_dict(self) -> dict:
        return {
            "sequence": self.sequence.name,
            "alias": self.sequence.alias,
            "system": self.system,
            "published": {
                "log": {key: value.to_json() for key, value in self.log.items()},
                "chart": {key: value.to_json() for key, value in self.chart.items()},
            },
            "reproduced": self.reproduced,
            "sha256_verified": self.verified,
        }


def score_run(groundtruth_file: Path, poses_file: Path) -> dict:
    """The study's figures and the coverage-aware ones of one run (bare files: TUM's own association),
    scored as ``viewslam evaluate --rpe-mode tum`` scores the files."""
    estimate = read_estimate_file(poses_file, TrajectoryFormat.TUM)
    evaluation = score_estimate(read_groundtruth(groundtruth_file), estimate, STUDY_SCORING)
    span = evaluation.coverage.span
    lost = evaluation.coverage.lost_intervals
    stopped = evaluation.coverage.stopped_at
    stats = lambda series: None if series is None else series.stats()  # noqa: E731
    ate, trans, rot, penalized = (
        stats(evaluation.ate),
        stats(evaluation.rpe_trans),
        stats(evaluation.rpe_rot),
        stats(evaluation.penalized_ate),
    )
    return {
        "ate_rmse": ate and ate["rmse"],
        "ate_pairs": ate and ate["n"],
        "rpe_trans_rmse": trans and trans["rmse"],
        "rpe_rot_rmse_deg": rot and rot["rmse"],
        "rpe_pairs": trans and trans["n"],
        "rpe_mode": RpeMode.TUM,
        "coverage": evaluation.coverage.ratio,
        "penalized_ate_rmse": penalized and penalized["rmse"],
        "poses": len(estimate.trajectory),
        "lost_intervals": [[start, end] for start, end in lost],
        "span": [span.start, span.end],
        "duration_s": span.end - span.start,
        "stopped_at_s": None if stopped is None else stopped - span.start,
    }


def replay(files: dict[str, tuple[Path, bool]], sequences: list[StudySequence]) -> tuple[list[Run], list[dict]]:
    """Rows for ``sequences`` × both systems and every discrepancy, from the fetched ``files``
    (relative path → (local path, hash checked))."""
    charts = {
        script: parse_chart(files[script][0], tuple(system.chart_variable for system in SYSTEMS)) for script in CHARTS
    }
    runs = []
    for sequence in sequences:
        groundtruth = files[groundtruth_path(sequence)]
        for system in SYSTEMS:
            poses, log = files[poses_path(sequence, system)], files[log_path(sequence, system)]
            chart = {}
            for script, figure in CHARTS.items():
                labels, bars = charts[script]
                if sequence.label in labels:
                    chart[figure] = bars[system.chart_variable][labels.index(sequence.label)]
            runs.append(
                Run(
                    sequence,
                    system.name,
                    score_run(groundtruth[0], poses[0]),
                    parse_log(log[0]),
                    chart,
                    groundtruth[1] and poses[1] and log[1],
                )
            )
    return runs, discrepancies(runs, charts)


def discrepancies(runs: list[Run], charts: dict) -> list[dict]:
    """Every published figure that does not print as its run's, and every chart bar placed under another label."""
    found = []
    by_key = {(run.sequence.name, run.system): run for run in runs}
    for run in runs:
        for figure in FIGURES + ("ate_pairs", "rpe_pairs"):
            printed = run.log.get(figure)
            value = run.reproduced.get(figure)
            if printed is not None and not printed.agrees(value):
                found.append(_entry(run, figure, "log", printed, value, "differs"))
        for figure, printed in run.chart.items():
            if figure == "time_s":  # no run gives a time: the chart is checked against the log
                logged = run.log.get("time_s")
                if logged is not None and not printed.agrees(logged.value) and not logged.agrees(printed.value):
                    entry = _entry(run, figure, "chart", printed, logged.value, "differs from the log")
                    entry["text"] = (
                        f"{run.sequence.alias} {run.system}: the chart shows processing time "
                        f"{printed.value:.{printed.decimals}f} s, the result log "
                        f"{logged.value:.{logged.decimals}f} s"
                    )
                    found.append(entry)
                continue
            value = run.reproduced.get(figure)
            if printed.agrees(value):
                continue
            other = next(
                (
                    other
                    for (name, system), other in by_key.items()
                    if system == run.system
                    and name != run.sequence.name
                    and printed.agrees(other.reproduced.get(figure))
                ),
                None,
            )
            entry = _entry(run, figure, "chart", printed, value, "misplaced" if other else "differs")
            if other is not None:
                entry["belongs_to"] = other.sequence.name
                entry["text"] += f"; it is {other.sequence.alias}'s figure"
            elif run.log.get(figure) is not None and printed.agrees(run.log[figure].value):
                entry["text"] += "; as the result log prints it"
            found.append(entry)
    return found


def _entry(run: Run, figure: str, source: str, printed: Printed, value: float | None, kind: str) -> dict:
    where = "result log" if source == "log" else "chart"
    shown = "none" if value is None else f"{value:.{max(printed.decimals, 6)}f}"
    against = "the log's" if kind == "differs from the log" else "the run gives"
    text = (
        f"{run.sequence.alias} {run.system}: the {where} shows {FIGURE_NAMES.get(figure, figure)} "
        f"{printed.value:.{printed.decimals}f}, {against} {shown}"
    )
    return {
        "sequence": run.sequence.name,
        "system": run.system,
        "figure": figure,
        "source": source,
        "kind": kind,
        "published": printed.value,
        "reproduced": value,
        "text": text,
    }


def all_sequences() -> list[StudySequence]:
    return list(SEQUENCES)
