"""What a recording costs: size per frame, time next to the pipelines', peak memory.

    python -m benchmarks.record [--scenario 360_kidnap | --sequence TUM_FOLDER] [--frames 200]
                                [--repeats 3] [--memory-frames 2500]

1. Size and time: records ``--frames`` frames of a synthetic scenario at 640x480 (or of a
   TUM folder) with both pipelines. Size is the .rrd's bytes per frame. Time is measured
   two ways: the CPU time spent inside the recorder's calls (events, images, evaluation
   series, on the recorder's own thread) as a share of the pipelines' own wall time, and the wall time of
   `record` against the same pipelines run with no sink at all, the frame loop alone (this
   also charges Rerun's background encoder and writer threads, and the run's diagnosis and
   evaluation). Both are
   run ``--repeats`` times, alternately, after a short run of each that loads what they load
   once; the figures are the median run's, with the range of the ratio over the repeats (the
   machine's other load moves single runs).
2. Memory: both pipelines recorded over ``--memory-frames`` frames in a process of its own,
   which reports its peak RSS. Rendering thousands of synthetic frames takes longer than
   the measurement itself, so the long sequence plays the short one forwards, backwards,
   forwards... (continuous motion, time running on, groundtruth following the frames).
   ``--memory-frames 0`` skips it.

Prints the figures as JSON and writes their table into docs/recording.md (the figure block
``record-cost`` for the default scenario, ``record-cost-<folder>`` for a TUM folder that has
one), stamped with the command, the machine, the load before and after the run and the date:
too costly for the test suite, so never re-run there.
"""

import argparse
import json
import multiprocessing
import os
import resource
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any
from unittest.mock import patch

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth import cached_scenario
from viewer_slam.pipelines.base import PIPELINE_MODULES
from viewer_slam.pipelines.run import run_pipeline
from viewer_slam.record import session
from viewer_slam.record.command import record
from viewer_slam.record.session import record_sequence
from viewer_slam.runs.service import build_run

from . import lab
from .figures import REPO, invocation, stamp, write_block
from .streams import PingPong

RESOLUTION = (640, 480)
WARM_UP_FRAMES = 10
# TUM folders whose figures docs/recording.md shows, by folder name, and their block.
SEQUENCE_BLOCKS = {"rgbd_dataset_freiburg1_rpy_200": "record-cost-fr1-rpy-200"}
DOCUMENT = REPO / "docs" / "recording.md"


class Stopwatch:
    """Accumulates the CPU time of the calling thread spent in the functions it wraps."""

    def __init__(self) -> None:
        self.seconds = 0.0

    def wrap(self, function: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds += time.thread_time() - start

        return timed


def timed_recording(folder: Path, frames: int, out: Path) -> tuple[dict[str, Any], float, float]:
    """Record with every recorder entry point timed; (report, recorder seconds, wall seconds)."""
    watch = Stopwatch()

    class TimedRecorder(session.PipelineRecorder):
        __call__ = watch.wrap(session.PipelineRecorder.__call__)
        begin_frame = watch.wrap(session.PipelineRecorder.begin_frame)

    with (
        patch.object(session, "PipelineRecorder", TimedRecorder),
        patch.object(session, "log_frame_image", watch.wrap(session.log_frame_image)),
        patch.object(session, "log_evaluation", watch.wrap(session.log_evaluation)),
    ):
        start = time.perf_counter()
        result = record(str(folder), out=out, max_frames=frames, quiet=True)
        wall = time.perf_counter() - start
    return result.report, watch.seconds, wall


def bare_pipelines(folder: Path, frames: int) -> float:
    """Wall seconds of the pipelines' frame loops alone: no sink, no diagnosis, no scoring (the
    run service's first step, which ``record`` runs with everything else around it)."""
    sequence = open_source(folder)
    start = time.perf_counter()
    for name in PIPELINE_MODULES:
        run_pipeline(sequence, name, max_frames=frames)
    return time.perf_counter() - start


def size_and_time(folder: Path, frames: int, repeats: int, scratch: Path) -> dict:
    """Recording against no sink, ``repeats`` times alternately after a warm-up of each; the
    median run's figures and the range of the wall-time ratio."""
    timed_recording(folder, min(frames, WARM_UP_FRAMES), scratch / "warm-up.rrd")
    bare_pipelines(folder, min(frames, WARM_UP_FRAMES))
    runs = []
    for repeat in range(repeats):
        out = scratch / f"size-{repeat}.rrd"
        report, recorder_s, record_wall_s = timed_recording(folder, frames, out)
        bare_s = bare_pipelines(folder, frames)
        pipeline_s = sum(block["timing"]["total_s"] for block in report["pipelines"].values())
        runs.append(
            {
                "kib_per_frame": out.stat().st_size / 1024 / frames,
                "recorder_s": recorder_s,
                "pipelines_s": pipeline_s,
                "recorder_share_of_pipelines": recorder_s / pipeline_s,
                "record_wall_s": record_wall_s,
                "bare_pipelines_wall_s": bare_s,
                "wall_ratio": record_wall_s / bare_s,
                "fps": {name: block["timing"]["fps"] for name, block in report["pipelines"].items()},
            }
        )
        print(f"repeat {repeat + 1}: record {record_wall_s:.2f} s, no sink {bare_s:.2f} s", file=sys.stderr)
    ratios = sorted(run["wall_ratio"] for run in runs)
    median = min(runs, key=lambda run: (abs(run["wall_ratio"] - ratios[len(ratios) // 2]), run["wall_ratio"]))
    return {**median, "wall_ratios": [run["wall_ratio"] for run in runs]}


def measure_memory(folder: Path, frames: int, out: Path) -> dict[str, Any]:
    """In a process of its own: record both pipelines over the ping-pong sequence; peak RSS in GiB."""
    sequence = PingPong(open_source(folder), frames)
    runs = {name: build_run(spec, sequence) for name, spec in lab.pipeline_specs(list(PIPELINE_MODULES)).items()}
    result = record_sequence(sequence, runs, out, quiet=True)
    return {
        "peak_rss_gib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
        "kib_per_frame": out.stat().st_size / 1024 / frames,
        "fps": {name: block["timing"]["fps"] for name, block in result.report["pipelines"].items()},
    }


def peak_memory(folder: Path, frames: int, out: Path) -> dict[str, Any]:
    """:func:`measure_memory` in a fresh process, whose peak RSS is the recording's alone."""
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as process:
        return process.submit(measure_memory, folder, frames, out).result()


def table(results: dict) -> str:
    """The figures as docs/recording.md shows them, beside their targets."""
    frames = results["frames"]
    ratios = results["wall_ratios"]
    spread = f"; {len(ratios)} runs: {min(ratios):.2f}–{max(ratios):.2f}" if len(ratios) > 1 else ""
    rows = [
        ("| figure | measured | target |", "|---|---|---|"),
        (
            f"| size, {frames} frames, both pipelines | **{results['kib_per_frame']:.1f} KiB per frame** "
            f"({results['kib_per_frame'] * frames / 1024:.1f} MiB) | ≤ 60 KiB |",
        ),
        (
            f"| CPU time inside the recorder (on its own thread) / the pipelines' own wall time, {frames} frames | "
            f"**{results['recorder_share_of_pipelines']:.1%}** ({results['recorder_s']:.2f} s of "
            f"{results['pipelines_s']:.2f} s) | ≤ 25 % |",
        ),
        (
            f"| wall time of `record` / the same pipelines with no sink, {frames} frames | "
            f"**{results['wall_ratio']:.2f}×** ({results['record_wall_s']:.2f} s against "
            f"{results['bare_pipelines_wall_s']:.2f} s{spread}) | ≤ 1.2× |",
        ),
    ]
    memory = results.get("memory")
    if memory:
        rows += [
            (
                f"| size, {memory['frames']:,} frames, both pipelines | **{memory['kib_per_frame']:.1f} KiB per "
                f"frame** ({memory['kib_per_frame'] * memory['frames'] / 1024:.0f} MiB) | ≤ 60 KiB |",
            ),
            (
                f"| peak RSS, {memory['frames']:,} frames, both pipelines, one process | "
                f"**{memory['peak_rss_gib']:.2f} GiB** | ≤ 3 GB |",
            ),
        ]

    def rates(fps: dict[str, float]) -> str:
        return " and ".join(f"{name} {value:.1f}" for name, value in fps.items())

    text = f"Frames/s while recording {frames} frames: {rates(results['fps'])}"
    if memory:
        text += f"; {memory['frames']:,} frames: {rates(memory['fps'])}"
    return "\n".join(line for row in rows for line in row) + f"\n\n{text}."


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.record", description=__doc__.splitlines()[0])
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--scenario", default="360_kidnap")
    source.add_argument("--sequence", type=Path, help="a TUM folder instead of a synthetic scenario")
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=3, help="record and no-sink runs, alternately")
    parser.add_argument("--memory-frames", type=int, default=2500)
    args = parser.parse_args(argv)
    load = os.getloadavg()[0]
    results = {"source": str(args.sequence) if args.sequence else args.scenario, "frames": args.frames}
    with tempfile.TemporaryDirectory() as scratch:
        if args.sequence:
            folder = args.sequence
        else:
            folder = cached_scenario(args.scenario, frames=args.frames, resolution=RESOLUTION)
            results["resolution"] = list(RESOLUTION)
        results.update(size_and_time(folder, args.frames, args.repeats, Path(scratch)))
        print(f"size and time done: {results['kib_per_frame']:.1f} KiB/frame", file=sys.stderr)
        if args.memory_frames:
            results["memory"] = {
                "frames": args.memory_frames,
                **peak_memory(folder, args.memory_frames, Path(scratch) / "memory.rrd"),
            }
    print(json.dumps(results, indent=2))
    block = (
        SEQUENCE_BLOCKS.get(args.sequence.resolve().name)
        if args.sequence
        else ("record-cost" if args.scenario == "360_kidnap" else None)
    )
    if block is None:
        return 0
    command = invocation(parser.prog, lab.arguments(argv))
    loads = f"Load average {load:.1f} before the run, {os.getloadavg()[0]:.1f} after."
    write_block(DOCUMENT, block, f"{stamp(command)} {loads}\n\n{table(results)}")
    return 0


if __name__ == "__main__":
    lab.main_of(main)
