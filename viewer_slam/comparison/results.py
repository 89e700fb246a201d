"""Two benchmark results folders compared row by row (`viewslam benchmark --compare`).

A results folder holds ``results.json`` (one row per sequence, run and trial) and ``runs/``: per
sequence, a report in `viewslam record`'s form (``runs/<sequence>.json``) with each run's
trajectory beside it (``runs/<sequence>.<run>.txt``), so every row compares exactly as
`viewslam diff` compares two reports. Folder B is compared against folder A.
"""

from dataclasses import dataclass
from pathlib import Path

from ..documents import read_json
from ..errors import InputError
from .compare import RunComparison, check_same_sequence, compare_runs, open_compared_sequence, same_sequence
from .reports import RecordReport, load_report

RUNS_FOLDER = "runs"


def runs_report_path(folder: Path, sequence: str) -> Path:
    """Where a results folder keeps the report of ``sequence`` (a row's sequence label)."""
    return Path(folder) / RUNS_FOLDER / f"{sequence.replace('/', '_')}.json"


@dataclass
class BenchmarkResults:
    """A results folder: its rows as (sequence, run, status) and the reports of the sequences with a run that ran."""

    folder: Path
    rows: list[tuple[str, str, str]]
    reports: dict[str, RecordReport]


@dataclass
class ResultsComparison:
    """Rows in both folders compared (B against A); ``not_compared`` the others as (sequence, run, why)."""

    a: BenchmarkResults
    b: BenchmarkResults
    runs: list[tuple[str, RunComparison]]
    not_compared: list[tuple[str, str, str]]


def load_results(folder: Path) -> BenchmarkResults:
    """Read a results folder, refusing in one line what is not one or was written by an older version."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError.at(folder, "not a benchmark results folder (no such folder)")
    if not (folder / "results.json").exists():
        raise InputError.at(folder, "not a benchmark results folder (no results.json)")
    data = read_json(folder / "results.json", "the benchmark results")
    if not isinstance(data, list) or not all(
        isinstance(row, dict) and all(isinstance(row.get(key), str) for key in ("sequence", "pipeline", "status"))
        for row in data
    ):
        raise InputError.at(folder, "not a benchmark results folder (results.json holds no result rows)")
    rows = _pair_rows(data)
    reports = {}
    for sequence in dict.fromkeys(sequence for sequence, _, status in rows if status == "ok"):
        path = runs_report_path(folder, sequence)
        if not path.is_file():
            raise InputError.at(
                folder,
                f"results of an older format (no {path.relative_to(folder)} with the runs' "
                f"reports and trajectories); run the benchmark again with this version",
            )
        reports[sequence] = load_report(path)
    return BenchmarkResults(folder, rows, reports)


def _pair_rows(data: list[dict]) -> list[tuple[str, str, str]]:
    """One (sequence, run, status) per pair: a pair run as several trials has a row per trial, and is
    ``ok`` when one of them ran (its report block holds them all)."""
    pairs: dict[tuple[str, str], str] = {}
    for row in data:
        key = (row["sequence"], row["pipeline"])
        pairs[key] = "ok" if pairs.get(key) == "ok" else row["status"]
    return [(sequence, run, status) for (sequence, run), status in pairs.items()]


def check_comparable(a: BenchmarkResults, b: BenchmarkResults) -> None:
    """Refuse two folders whose rows of one sequence label are of different sequences."""
    for sequence in a.reports.keys() & b.reports.keys():
        try:
            check_same_sequence(a.reports[sequence], b.reports[sequence])
        except InputError as error:
            raise InputError.at(
                a.folder, f"results of different sequences under the name {sequence!r}: {error}"
            ) from None


def check_planned_sequences(other: BenchmarkResults, planned: dict[str, dict]) -> None:
    """Before a benchmark runs: refuse ``other`` when a sequence label of both is another sequence there.

    ``planned`` maps each label about to run to its report's sequence block."""
    for sequence, block in planned.items():
        if sequence in other.reports and not same_sequence(other.reports[sequence].sequence, block):
            there = other.reports[sequence].sequence
            raise InputError.at(
                other.folder,
                f"results of different sequences under the name {sequence!r} "
                f"({there.get('name')}, {there.get('frames')} frames there; "
                f"{block['name']}, {block['frames']} frames here)",
            )


def compare_results(a: BenchmarkResults, b: BenchmarkResults) -> ResultsComparison:
    """Every (sequence, run) that ran in both folders, compared; the others named with the reason."""
    check_comparable(a, b)
    status_a = {(sequence, run): status for sequence, run, status in a.rows}
    status_b = {(sequence, run): status for sequence, run, status in b.rows}
    compared, not_compared, sequences = [], [], {}
    for sequence, run in dict.fromkeys([*status_b, *status_a]):
        key = (sequence, run)
        if key not in status_a or key not in status_b:
            not_compared.append((sequence, run, f"only in {'B' if key in status_b else 'A'}"))
        elif status_a[key] != "ok" or status_b[key] != "ok":
            failed = " and ".join(
                side for side, status in (("A", status_a[key]), ("B", status_b[key])) if status != "ok"
            )
            not_compared.append((sequence, run, f"failed in {failed}"))
        else:
            report_a, report_b = a.reports[sequence], b.reports[sequence]
            if sequence not in sequences:
                sequences[sequence] = open_compared_sequence(report_b, report_a)  # B's folder first: the newer
            compared.append((sequence, compare_runs(report_a.runs[run], report_b.runs[run], sequences[sequence])))
    return ResultsComparison(a, b, compared, not_compared)
