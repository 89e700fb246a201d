"""Speed, memory and accuracy of the rtabmap pipeline (the figures of docs/pipelines/rtabmap.md).

    python -m benchmarks.rtabmap            # all cases
    python -m benchmarks.rtabmap speed      # one case: speed, accuracy, memory or fidelity
    python -m benchmarks.rtabmap fidelity kidnap   # fidelity sequences whose name holds "kidnap"

Synthetic scenarios are generated into the cache on first use (minutes at 640x480).
Times are wall-clock on this machine; per-stage figures are medians over the frames or
locations on which the stage ran, and means per frame (the stage's share of the frame rate).
``--config`` and ``--param`` set parameters under every case's own, as ``viewslam record`` takes them.
"""

import argparse
import resource
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.resting import RestingStart
from viewer_slam.dataset.sources import RgbdSequence, open_source
from viewer_slam.dataset.synth.generate import cached_scenario
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.pipelines.events import Event, FrameTracked, GraphEdge
from viewer_slam.pipelines.run import PipelineRun

from . import lab
from .figures import TUM

REST_FRAMES = 60


def run(
    options: argparse.Namespace,
    name: str,
    frames: int,
    resolution: tuple[int, int],
    rest: int = 0,
    max_frames: int | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> tuple[RgbdSequence, PipelineRun, list[Event]]:
    """``name`` is a synthetic scenario or a TUM folder (then ``frames`` and ``resolution`` are unused);
    ``overrides`` the case's parameters, on top of ``options``' ``--config`` and ``--param``."""
    folder = Path(name) if Path(name).is_dir() else cached_scenario(name, frames=frames, resolution=resolution, seed=0)
    sequence = open_source(folder)
    events: list[Event] = []
    spec = lab.pipeline_spec("rtabmap", options, last=overrides)
    fed = RestingStart(sequence, rest) if rest else sequence
    result = lab.run(fed, spec, "rtabmap", max_frames=max_frames, sinks=[events.append]).run
    return sequence, result, events


def ate(sequence: RgbdSequence, trajectory: Trajectory | None) -> float | None:
    if trajectory is None or len(trajectory) < 2:
        return None
    return lab.ate_rmse(sequence.groundtruth, trajectory)


def stage_table(events) -> str:
    tracked = [e for e in events if isinstance(e, FrameTracked)]
    total = np.array([sum(e.timings_ms.values()) for e in tracked])
    lines = ["| stage | median ms (when run) | runs | mean ms per frame | share |", "|---|---|---|---|---|"]
    for stage in tracked[0].timings_ms:
        values = np.array([e.timings_ms[stage] for e in tracked])
        ran = values[values > 0]
        lines.append(
            f"| {stage} | {np.median(ran) if len(ran) else 0:.2f} | {len(ran)} | {values.mean():.2f} "
            f"| {values.sum() / total.sum():.0%} |"
        )
    lines.append(f"| all | {np.median(total):.2f} | {len(total)} | {total.mean():.2f} | 100% |")
    return "\n".join(lines)


def speed(options: argparse.Namespace) -> None:
    sequence, result, events = run(options, "long_office_household", 300, (640, 480))
    print("## Speed: long_office_household, 300 frames, 640x480, default parameters\n")
    print(stage_table(events))
    print(
        f"\nfps {result.fps:.1f} (wall, including image loading), median frame "
        f"{np.median([sum(e.timings_ms.values()) for e in events if isinstance(e, FrameTracked)]):.1f} ms, "
        f"locations {result.keyframes}, ATE {ate(sequence, result.trajectory):.3f} m\n"
    )


def accuracy(options: argparse.Namespace) -> None:
    print("## Accuracy (320x240, Rtabmap/DetectionRate 10)\n")
    print("| scenario | frames | ATE RMSE m | odometry ATE m | closures accepted/rejected | coverage |")
    print("|---|---|---|---|---|---|")
    for name, frames in (
        ("nostructure_texture_near_withloop", 150),
        ("nostructure_texture_near_withloop", 300),
        ("long_office_household", 300),
    ):
        sequence, result, _ = run(options, name, frames, (320, 240), overrides={"Rtabmap/DetectionRate": 10})
        groundtruth = sequence.groundtruth
        coverage = evaluate(groundtruth, result.trajectory).coverage.ratio if groundtruth is not None else float("nan")
        print(
            f"| {name} | {frames} | {ate(sequence, result.trajectory):.4f} | {ate(sequence, result.odometry):.4f} "
            f"| {result.loop_closures_accepted}/{result.loop_closures_rejected} | {coverage:.2f} |"
        )
    print()


def memory(options: argparse.Namespace) -> None:
    print("## Memory: long_office_household, 2,500 frames, 320x240, default parameters\n")
    print(
        "| Rtabmap/MemoryThr | start | max WM | final WM / LTM | words | vocabulary+bayes ms per location (median) "
        "| loop closures to the first 10 locations | ATE m | fps |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for threshold, rest in ((0, 0), (30, 0), (30, REST_FRAMES)):
        sequence, result, events = run(
            options, "long_office_household", 2500, (320, 240), rest, overrides={"Rtabmap/MemoryThr": threshold}
        )
        tracked = [e for e in events if isinstance(e, FrameTracked)]
        per_location = [
            e.timings_ms["vocabulary"] + e.timings_ms["bayes"] for e in tracked if e.timings_ms["bayes"] > 0
        ]
        early = [
            e
            for e in events
            if isinstance(e, GraphEdge) and e.accepted and e.detection != "odometry" and e.from_keyframe < 10
        ]
        last = tracked[-1].metrics
        start = f"rests {rest} frames" if rest else "moving"
        print(
            f"| {threshold or 'off'} | {start} | {max(e.metrics['wm'] for e in tracked)} | {last['wm']} / {last['ltm']} "
            f"| {last['words']} | {np.median(per_location):.1f} | {len(early)} "
            f"| {ate(sequence, result.trajectory):.3f} | {result.fps:.1f} |"
        )
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak RSS of the process over the three runs: {peak_mb:.0f} MB\n")


def largest_step_error(sequence, trajectory) -> float:
    """Largest difference (m) between the estimated and the true motion of consecutive poses."""
    if len(trajectory) < 2:
        return 0.0
    truth, _ = sequence.groundtruth_at(trajectory.timestamps)
    estimated = np.linalg.inv(trajectory.poses[:-1]) @ trajectory.poses[1:]
    true = np.linalg.inv(truth[:-1]) @ truth[1:]
    return float(np.linalg.norm(estimated[:, :3, 3] - true[:, :3, 3], axis=1).max())


def fidelity(options: argparse.Namespace) -> None:
    """The cheap figures of the pipeline doc's fidelity section: real excerpts at 640x480,
    synthetic scenarios at 320x240, default parameters unless stated; with ``options.only``, the
    cases whose sequence's name holds it."""
    tum = TUM
    mono = {"g2o/Baseline": 0.0}
    cases: list[tuple[str, int, int | None, dict[str, float]]] = [
        (str(tum / "rgbd_dataset_freiburg1_rpy"), 0, None, {}),
        (str(tum / "rgbd_dataset_freiburg1_rpy"), 0, None, mono),
        (str(tum / "rgbd_dataset_freiburg1_rpy_200"), 0, None, {}),
        (str(tum / "rgbd_dataset_freiburg1_rpy_200"), 0, None, mono),
        ("nostructure_texture_near_withloop", 600, None, {}),
        ("nostructure_texture_near_withloop", 150, None, {"Rtabmap/DetectionRate": 10}),
        ("nostructure_notexture_near_withloop", 300, 150, {}),
        ("desk_with_person", 300, None, {}),
        ("360_kidnap", 300, None, {}),
        ("360_kidnap", 300, None, {"Odom/ResetCountdown": 5}),
        ("360_kidnap", 300, None, {"Odom/ResetCountdown": 5, "Rtabmap/DetectionRate": 5}),
        ("360_kidnap_norevisit", 300, None, {}),
    ]
    if options.only:
        cases = [case for case in cases if options.only in case[0]]
    print(
        "| sequence | frames | parameters | frames with a pose | ATE RMSE m | odometry ATE m "
        "| loop closures (appearance / proximity) | largest step error m |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, frames, max_frames, overrides in cases:
        sequence, result, events = run(options, name, frames, (320, 240), max_frames=max_frames, overrides=overrides)
        closures = [
            e.detection for e in events if isinstance(e, GraphEdge) and e.accepted and e.detection != "odometry"
        ]
        print(
            f"| {Path(name).name} | {result.frames} | {overrides or 'defaults'} | {len(result.trajectory)} "
            f"| {ate(sequence, result.trajectory) or float('nan'):.4f} "
            f"| {ate(sequence, result.odometry) or float('nan'):.4f} | {closures.count('appearance')} / {closures.count('proximity')} "
            f"| {largest_step_error(sequence, result.trajectory):.3f} |"
        )
    print()


CASES: dict[str, Callable[[argparse.Namespace], None]] = {
    "speed": speed,
    "accuracy": accuracy,
    "memory": memory,
    "fidelity": fidelity,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.rtabmap", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("case", nargs="?", choices=list(CASES), help="one case (default: all)")
    parser.add_argument("only", nargs="?", help="fidelity: only the sequences whose name holds this")
    lab.add_parameter_options(parser, "every case, under the case's own")
    options = parser.parse_args(argv)
    lab.pipeline_spec("rtabmap", options)  # the parameters checked before the first case runs
    for case in [options.case] if options.case else CASES:
        CASES[case](options)
    return 0


if __name__ == "__main__":
    lab.main_of(main)
