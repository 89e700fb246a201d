"""Speed, accuracy and memory of the rgbdslam pipeline (figures for docs/pipelines/rgbdslam.md).

    python benchmarks/rgbdslam.py speed  [--sequence SPEC] [--frames N] [--detectors ORB SIFT] [--set KEY=VALUE ...]
    python benchmarks/rgbdslam.py memory [--sequence SPEC] [--frames 2500] [--set KEY=VALUE ...]

``speed`` runs each detector over one sequence and prints frames per second (by the wall
clock, and by the process's CPU time, which a busy shared machine does not inflate), the median
and mean milliseconds per stage, and ATE RMSE after optimisation and of odometry alone.
``memory`` feeds a long stream (the sequence played forwards and backwards until
``--frames`` frames, so the camera keeps moving and the graph keeps growing) and prints
the process's peak resident set size. ``--set`` overrides parameters (e.g.
``backend_solver=cholmod``). Run each mode in its own process.
"""

import argparse
import os
import resource
import time
from itertools import chain, cycle, islice
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.frame import Frame
from viewer_slam.dataset.sources import open_source
from viewer_slam.errors import InputError
from viewer_slam.evaluation import evaluate
from viewer_slam.pipelines.events import FrameTracked
from viewer_slam.pipelines.params import apply_overrides
from viewer_slam.pipelines.rgbdslam import RgbdSlamParams
from viewer_slam.pipelines.run import run_pipeline

DEFAULT_SEQUENCE = str(Path(__file__).resolve().parents[1].parent / "shared/data/tum/rgbd_dataset_freiburg1_rpy")
STAGES = ("features", "matching", "ransac", "emm", "optimisation", "map")


def process_cpu_s() -> float:
    """CPU seconds of this process: the speed on an otherwise idle core, whatever else runs."""
    times = os.times()
    return times.user + times.system


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class PingPong:
    """A sequence played forwards, backwards, forwards... as one continuous stream of
    ``length`` frames with evenly spaced timestamps (no groundtruth)."""

    def __init__(self, sequence, length: int):
        self.sequence, self.length = sequence, length
        self.camera, self.name, self.path, self.groundtruth = sequence.camera, sequence.name, sequence.path, None

    def __len__(self) -> int:
        return self.length

    def frames(self, max_frames=None, stride=1):
        count = len(self.sequence)
        order = cycle(chain(range(count), range(count - 2, 0, -1)))
        period = float(np.median(np.diff(self.sequence.timestamps)))
        for index, source in enumerate(islice(order, min(self.length, max_frames or self.length))):
            frame = self.sequence.frame(source)
            yield Frame(index, index * period, frame.rgb, frame.depth)


def speed(args) -> None:
    sequence = open_source(args.sequence, frames=args.frames)
    print(f"sequence {sequence.name}: {min(len(sequence), args.frames or len(sequence))} frames, "
          f"{sequence.camera.width}x{sequence.camera.height}")
    header = "| detector | fps (wall) | fps (CPU time) | " + " | ".join(f"{s} ms (median / mean)" for s in STAGES) + \
             " | keyframes | loops accepted | ATE RMSE m | odometry ATE RMSE m | peak RSS MB |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for detector in args.detectors:
        params = apply_overrides(RgbdSlamParams(), {**args.overrides, "feature_detector_type": detector}, "benchmark",
                                text=True)
        stage_ms = {stage: [] for stage in STAGES}

        def collect(event):
            if isinstance(event, FrameTracked):
                for stage in STAGES:
                    stage_ms[stage].append(event.timings_ms.get(stage, 0.0))  # noqa: B023  (called in this iteration)

        cpu_start = process_cpu_s()
        run = run_pipeline(sequence, "rgbdslam", params, seed=0, max_frames=args.frames, sinks=[collect])
        cpu_fps = run.frames / (process_cpu_s() - cpu_start)
        ate = odometry_ate = float("nan")
        if sequence.groundtruth is not None and len(run.trajectory.timestamps):
            ate = evaluate(sequence.groundtruth, run.trajectory).ate.stats()["rmse"]
            odometry_ate = evaluate(sequence.groundtruth, run.odometry).ate.stats()["rmse"]
        cells = " | ".join(f"{np.median(v):.1f} / {np.mean(v):.1f}" for v in stage_ms.values())
        print(f"| {detector} | {run.fps:.1f} | {cpu_fps:.1f} | {cells} | {run.keyframes} | {run.loop_closures_accepted} "
              f"| {ate:.4f} | {odometry_ate:.4f} | {peak_rss_mb():.0f} |", flush=True)


def memory(args) -> None:
    sequence = PingPong(open_source(args.sequence), args.frames)
    before = peak_rss_mb()
    start = time.perf_counter()
    run = run_pipeline(sequence, "rgbdslam", apply_overrides(RgbdSlamParams(), args.overrides, "benchmark", text=True),
                       seed=0)
    print(f"{run.frames} frames ({sequence.name} forwards and backwards), {run.keyframes} nodes, "
          f"{run.loop_closures_accepted} loop closures accepted, {len(run.trajectory.timestamps)} poses, "
          f"{time.perf_counter() - start:.0f} s ({run.fps:.1f} fps)")
    print(f"peak RSS {peak_rss_mb():.0f} MB (after imports and before the run: {before:.0f} MB)")


def override(item: str) -> tuple[str, str]:
    key, separator, value = item.partition("=")
    if not separator or not key:
        raise argparse.ArgumentTypeError(f"{item!r}: expected KEY=VALUE")
    return key, value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mode", choices=("speed", "memory"))
    parser.add_argument("--sequence", default=DEFAULT_SEQUENCE, help="TUM folder or synthetic scenario name")
    parser.add_argument("--frames", type=int, default=None)
    parser.add_argument("--detectors", nargs="+", default=["ORB", "SIFT"])
    parser.add_argument("--set", nargs="*", type=override, default=[], metavar="KEY=VALUE", help="parameter overrides")
    args = parser.parse_args()
    args.overrides = dict(args.set)
    try:
        if args.mode == "speed":
            speed(args)
        else:
            args.frames = args.frames or 2500
            memory(args)
    except InputError as error:
        parser.error(str(error))


if __name__ == "__main__":
    main()
