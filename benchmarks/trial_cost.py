"""The cost of one benchmark trial, into docs/benchmark.md (the figure block ``trial-cost``).

    python -m benchmarks.trial_cost [SEQUENCE ...] [--scenario-frames N] [--resolution WxH]
                                    [--trials N] [--record]

Runs the tasks `viewslam benchmark SEQUENCE --trials N` plans, one after another in this
process, through the benchmark's own task function (no pool, no cache): each timed by wall
clock and by this process's CPU time, which other load on a shared machine does not inflate,
and weighed by what it sends back to the driver (its pickled result; with ``--record`` the
recording and the files beside it too), the traffic a cluster carries per trial. Rendering
a synthetic scenario comes before and is not counted.
"""

import argparse
import os
import pickle
import statistics
import sys
import time

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

from viewer_slam.benchmark.plan import plan_tasks
from viewer_slam.benchmark.runner import execute_task
from viewer_slam.cli.options import parse_resolution

from . import lab
from .figures import REPO, invocation, scratch, stamp, write_block

DOCUMENT = REPO / "docs" / "benchmark.md"


def measure(options: argparse.Namespace) -> list[dict]:
    """Every task of the plan run and measured, in plan order."""
    recordings = scratch() if options.record else None
    tasks = plan_tasks(
        options.sequences,
        ["rgbdslam", "rtabmap"],
        scenario_frames=options.scenario_frames,
        resolution=parse_resolution(options.resolution),
        trials=options.trials,
        recordings=recordings,
    )
    measured = []
    for task in tasks:
        wall, cpu = time.perf_counter(), lab.process_cpu_s()
        result = execute_task(task)
        wall, cpu = time.perf_counter() - wall, lab.process_cpu_s() - cpu
        if not result.ok:
            raise RuntimeError(f"{task.label}: {result.error}")
        measured.append(
            {
                "sequence": task.name,
                "pipeline": task.pipeline,
                "trial": task.trial,
                "seed": task.seed,
                "frames": result.frames,
                "cpu_s": cpu,
                "wall_s": wall,
                "returned_kb": len(pickle.dumps(result)) / 1000,
            }
        )
        print(f"{task.label}: {cpu:.1f} s CPU, {wall:.1f} s wall", file=sys.stderr, flush=True)
    return measured


def table(measured: list[dict]) -> str:
    lines = [
        "| Sequence | Pipeline | Trial (seed) | Frames | CPU [s] | Wall [s] | CPU per frame [ms] | Returned [kB] |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    for row in measured:
        lines.append(
            f"| {row['sequence']} | {row['pipeline']} | {row['trial']} ({row['seed']}) | {row['frames']} "
            f"| {row['cpu_s']:.1f} | {row['wall_s']:.1f} | {1000 * row['cpu_s'] / row['frames']:.0f} "
            f"| {row['returned_kb']:,.0f} |"
        )
    for pipeline in dict.fromkeys(row["pipeline"] for row in measured):
        cpu = [row["cpu_s"] for row in measured if row["pipeline"] == pipeline]
        lines.append(f"| **median** | {pipeline} | | | {statistics.median(cpu):.1f} | | | |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    arguments = lab.arguments(argv)
    parser = argparse.ArgumentParser(prog="python -m benchmarks.trial_cost", description=__doc__.splitlines()[0])
    parser.add_argument("sequences", nargs="*", default=["360_kidnap"])
    parser.add_argument("--scenario-frames", type=int, default=120)
    parser.add_argument("--resolution", default="640x480")
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--record", action="store_true", help="record every task, as `benchmark --record` does")
    options = parser.parse_args(arguments)
    load = os.getloadavg()[0]
    measured = measure(options)
    text = (
        f"{stamp(invocation(parser.prog, arguments))} Load average {load:.1f} at the start (other work shared the cores: "
        f"compare CPU seconds, not wall).\n\n{table(measured)}"
    )
    write_block(DOCUMENT, "trial-cost", text)
    print(text)
    return 0


if __name__ == "__main__":
    lab.main_of(main)
