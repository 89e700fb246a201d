"""Speed, accuracy and memory of the rgbdslam pipeline (figures for docs/pipelines/rgbdslam.md).

    python -m benchmarks.rgbdslam speed  [--sequence SPEC] [--frames N] [--detectors ORB SIFT] [--param KEY=VALUE ...]
    python -m benchmarks.rgbdslam memory [--sequence SPEC] [--frames 2500] [--param KEY=VALUE ...]

``speed`` runs each detector over one sequence and prints frames per second (by the wall
clock, and by the process's CPU time, which a busy shared machine does not inflate), the median
and mean milliseconds per stage, and ATE RMSE after optimisation and of odometry alone.
``memory`` feeds a long stream (the sequence played forwards and backwards until
``--frames`` frames, so the camera keeps moving and the graph keeps growing) and prints
the process's peak resident set size. ``--param`` and ``--config`` set parameters as
``viewslam record`` takes them (e.g. ``--param backend_solver=cholmod``). Run each mode in its
own process.
"""

import argparse
import resource

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.sources import open_source
from viewer_slam.pipelines.events import Event, FrameTracked

from . import lab
from .figures import TUM
from .streams import PingPong

DEFAULT_SEQUENCE = str(TUM / "rgbd_dataset_freiburg1_rpy")
STAGES = ("features", "matching", "ransac", "emm", "optimisation", "map")


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def speed(args: argparse.Namespace) -> None:
    sequence = open_source(args.sequence, frames=args.frames)
    print(
        f"sequence {sequence.name}: {min(len(sequence), args.frames or len(sequence))} frames, "
        f"{sequence.camera.width}x{sequence.camera.height}"
    )
    header = (
        "| detector | fps (wall) | fps (CPU time) | "
        + " | ".join(f"{s} ms (median / mean)" for s in STAGES)
        + " | keyframes | loops accepted | ATE RMSE m | odometry ATE RMSE m | peak RSS MB |"
    )
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for detector in args.detectors:
        spec = lab.pipeline_spec("rgbdslam", args, last={"feature_detector_type": detector})
        stage_ms: dict[str, list[float]] = {stage: [] for stage in STAGES}

        def collect(event: Event) -> None:
            if isinstance(event, FrameTracked):
                for stage in STAGES:
                    stage_ms[stage].append(event.timings_ms.get(stage, 0.0))  # noqa: B023  (called in this iteration)

        cpu_start = lab.process_cpu_s()
        run = lab.run(sequence, spec, "rgbdslam", max_frames=args.frames, sinks=[collect]).run
        cpu_fps = run.frames / (lab.process_cpu_s() - cpu_start)
        ate, odometry_ate = (
            lab.ate_rmse(sequence.groundtruth, trajectory) for trajectory in (run.trajectory, run.odometry)
        )
        cells = " | ".join(f"{np.median(v):.1f} / {np.mean(v):.1f}" for v in stage_ms.values())
        print(
            f"| {detector} | {run.fps:.1f} | {cpu_fps:.1f} | {cells} | {run.keyframes} | {run.loop_closures_accepted} "
            f"| {ate:.4f} | {odometry_ate:.4f} | {peak_rss_mb():.0f} |",
            flush=True,
        )


def memory(args: argparse.Namespace) -> None:
    source = open_source(args.sequence)
    sequence = PingPong(source, args.frames, start=0.0)
    spec = lab.pipeline_spec("rgbdslam", args)
    before = peak_rss_mb()
    run = lab.run(sequence, spec, "rgbdslam").run
    print(
        f"{run.frames} frames ({source.name} forwards and backwards), {run.keyframes} nodes, "
        f"{run.loop_closures_accepted} loop closures accepted, {len(run.trajectory.timestamps)} poses, "
        f"{run.total_s:.0f} s ({run.fps:.1f} fps)"
    )
    print(f"peak RSS {peak_rss_mb():.0f} MB (after imports and before the run: {before:.0f} MB)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.rgbdslam", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("mode", choices=("speed", "memory"))
    parser.add_argument("--sequence", default=DEFAULT_SEQUENCE, help="TUM folder or synthetic scenario name")
    parser.add_argument("--frames", type=int, default=None)
    parser.add_argument("--detectors", nargs="+", default=["ORB", "SIFT"])
    lab.add_parameter_options(parser, "rgbdslam (--detectors sets feature_detector_type)")
    args = parser.parse_args(argv)
    if args.mode == "speed":
        speed(args)
    else:
        args.frames = args.frames or 2500
        memory(args)
    return 0


if __name__ == "__main__":
    lab.main_of(main)
