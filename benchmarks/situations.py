"""The seven synthetic situations of the study x both pipelines, into docs/benchmark.md.

    python -m benchmarks.situations [--frames N] [--resolution WxH] [--jobs N] [--out DIR]
    python -m benchmarks.situations --redraw

Generates the scenarios first, one process per job (rendering dominates a cold run), then
runs ``viewslam benchmark`` on them, copies its charts to ``docs/images/`` and writes its
results table and findings into docs/benchmark.md (the figure block ``situations``), stamped with
the command, the machine and the date: too costly for the test suite, so never re-run there.
``--redraw`` runs nothing: it draws the charts of ``docs/images/`` again, with the current
chart code, from the table the last run wrote into docs/benchmark.md (its numbers as printed).
"""

import argparse
import shutil
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path
from typing import Any

from viewer_slam.atomic import StagedFiles
from viewer_slam.benchmark.command import benchmark
from viewer_slam.benchmark.plots import plot_all
from viewer_slam.cli.options import parse_resolution
from viewer_slam.dataset.synth import SCENARIOS, cached_scenario

from . import lab
from .figures import REPO, invocation, stamp, write_block, written

IMAGES = REPO / "docs" / "images"
DOCUMENT = REPO / "docs" / "benchmark.md"

# The charted columns of the results table, by their titles there.
CHARTED = {
    "ATE RMSE [m]": "ate_rmse",
    "RPE trans RMSE [m]": "rpe_trans_rmse",
    "RPE rot RMSE [deg]": "rpe_rot_rmse",
    "Time [s]": "time_s",
    "Coverage": "coverage",
    "Penalised ATE RMSE [m]": "penalized_ate_rmse",
}


def documented_rows(document: str) -> list[dict[str, Any]]:
    """The situations block's results table as chart rows; "-" is a score that does not exist."""
    table = [line for line in written(document, "situations").splitlines() if line.startswith("| ")]  # not "|---|"
    header = [cell.strip() for cell in table[0].strip("|").split("|")]
    rows = []
    for line in table[1:]:
        cells = dict(zip(header, (cell.strip() for cell in line.strip("|").split("|"))))
        row: dict[str, Any] = {"sequence": cells["Sequence"], "pipeline": cells["Pipeline"], "status": cells["Status"]}
        for title, metric in CHARTED.items():
            text = cells[title].removesuffix("%").strip()
            row[metric] = None if text == "-" else float(text) / (100 if title == "Coverage" else 1)
        rows.append(row)
    return rows


def redraw() -> int:
    with StagedFiles() as staged:
        for path in plot_all(documented_rows(DOCUMENT.read_text()), IMAGES, staged):
            print(path)
        staged.commit()
    return 0


def main(argv: list[str] | None = None) -> int:
    arguments = lab.arguments(argv)
    parser = argparse.ArgumentParser(prog="python -m benchmarks.situations", description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=None, help="frames per scenario (default: each one's own)")
    parser.add_argument("--resolution", default="640x480")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("benchmark-results/situations"))
    parser.add_argument("--redraw", action="store_true", help="only draw the charts again from docs/benchmark.md")
    options = parser.parse_args(arguments)
    if options.redraw:
        return redraw()
    generate = partial(cached_scenario, frames=options.frames, resolution=parse_resolution(options.resolution))
    with ProcessPoolExecutor(options.jobs) as pool:
        for name, folder in zip(SCENARIOS, pool.map(generate, SCENARIOS)):
            print(f"{name}: {folder}", flush=True)
    benchmark(
        scenario_frames=options.frames,
        resolution=parse_resolution(options.resolution),
        jobs=options.jobs,
        out=options.out,
        quiet=False,
    )
    IMAGES.mkdir(parents=True, exist_ok=True)
    for chart in sorted(options.out.glob("benchmark_*")):
        shutil.copy2(chart, IMAGES / chart.name)
    report = (options.out / "report.md").read_text()
    table_and_findings = report[report.index("| Sequence |") : report.index("\n## Charts")].replace(
        "## Findings", "**Findings** (written by the benchmark):"
    )
    write_block(DOCUMENT, "situations", f"{stamp(invocation(parser.prog, arguments))}\n\n{table_and_findings.strip()}")
    return 0


if __name__ == "__main__":
    lab.main_of(main)
