"""Speed, memory and accuracy of the rtabmap pipeline (the figures of docs/pipelines/rtabmap.md).

    .venv/bin/python benchmarks/rtabmap.py            # all cases
    .venv/bin/python benchmarks/rtabmap.py speed      # one case: speed, accuracy, memory or fidelity
    .venv/bin/python benchmarks/rtabmap.py fidelity kidnap   # fidelity sequences whose name holds "kidnap"

Synthetic scenarios are generated into the cache on first use (minutes at 640x480).
Times are wall-clock on this machine; per-stage figures are medians over the frames or
locations on which the stage ran, and means per frame (the stage's share of the frame rate).
"""

import resource
import sys
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.resting import RestingStart
from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth.generate import cached_scenario
from viewer_slam.evaluation import evaluate
from viewer_slam.pipelines.events import FrameTracked, GraphEdge
from viewer_slam.pipelines.params import apply_overrides
from viewer_slam.pipelines.rtabmap import RtabmapParams
from viewer_slam.pipelines.run import run_pipeline

REST_FRAMES = 60


def run(name: str, frames: int, resolution: tuple[int, int], rest: int = 0, max_frames: int | None = None,
        **overrides):
    """``name`` is a synthetic scenario or a TUM folder (then ``frames`` and ``resolution`` are unused)."""
    folder = Path(name) if Path(name).is_dir() else cached_scenario(name, frames=frames, resolution=resolution, seed=0)
    sequence = open_source(folder)
    events = []
    params = apply_overrides(RtabmapParams(), overrides, "benchmark")
    fed = RestingStart(sequence, rest) if rest else sequence
    result = run_pipeline(fed, "rtabmap", params, seed=0, max_frames=max_frames, sinks=[events.append])
    return sequence, result, events


def ate(sequence, trajectory) -> float | None:
    if trajectory is None or len(trajectory) < 2:
        return None
    return evaluate(sequence.groundtruth, trajectory).ate.stats()["rmse"]


def stage_table(events) -> str:
    tracked = [e for e in events if isinstance(e, FrameTracked)]
    total = np.array([sum(e.timings_ms.values()) for e in tracked])
    lines = ["| stage | median ms (when run) | runs | mean ms per frame | share |", "|---|---|---|---|---|"]
    for stage in tracked[0].timings_ms:
        values = np.array([e.timings_ms[stage] for e in tracked])
        ran = values[values > 0]
        lines.append(f"| {stage} | {np.median(ran) if len(ran) else 0:.2f} | {len(ran)} | {values.mean():.2f} "
                     f"| {values.sum() / total.sum():.0%} |")
    lines.append(f"| all | {np.median(total):.2f} | {len(total)} | {total.mean():.2f} | 100% |")
    return "\n".join(lines)


def speed() -> None:
    sequence, result, events = run("long_office_household", 300, (640, 480))
    print("## Speed: long_office_household, 300 frames, 640x480, default parameters\n")
    print(stage_table(events))
    print(f"\nfps {result.fps:.1f} (wall, including image loading), median frame "
          f"{np.median([sum(e.timings_ms.values()) for e in events if isinstance(e, FrameTracked)]):.1f} ms, "
          f"locations {result.keyframes}, ATE {ate(sequence, result.trajectory):.3f} m\n")


def accuracy() -> None:
    print("## Accuracy (320x240, Rtabmap/DetectionRate 10)\n")
    print("| scenario | frames | ATE RMSE m | odometry ATE m | closures accepted/rejected | coverage |")
    print("|---|---|---|---|---|---|")
    for name, frames in (("nostructure_texture_near_withloop", 150), ("nostructure_texture_near_withloop", 300),
                         ("long_office_household", 300)):
        sequence, result, _ = run(name, frames, (320, 240), **{"Rtabmap/DetectionRate": 10})
        coverage = evaluate(sequence.groundtruth, result.trajectory).coverage.ratio
        print(f"| {name} | {frames} | {ate(sequence, result.trajectory):.4f} | {ate(sequence, result.odometry):.4f} "
              f"| {result.loop_closures_accepted}/{result.loop_closures_rejected} | {coverage:.2f} |")
    print()


def memory() -> None:
    print("## Memory: long_office_household, 2,500 frames, 320x240, default parameters\n")
    print("| Rtabmap/MemoryThr | start | max WM | final WM / LTM | words | vocabulary+bayes ms per location (median) "
          "| loop closures to the first 10 locations | ATE m | fps |")
    print("|---|---|---|---|---|---|---|---|---|")
    for threshold, rest in ((0, 0), (30, 0), (30, REST_FRAMES)):
        sequence, result, events = run("long_office_household", 2500, (320, 240), rest,
                                       **{"Rtabmap/MemoryThr": threshold})
        tracked = [e for e in events if isinstance(e, FrameTracked)]
        per_location = [e.timings_ms["vocabulary"] + e.timings_ms["bayes"] for e in tracked
                        if e.timings_ms["bayes"] > 0]
        early = [e for e in events if isinstance(e, GraphEdge) and e.accepted and e.detection != "odometry"
                 and e.from_keyframe < 10]
        last = tracked[-1].metrics
        start = f"rests {rest} frames" if rest else "moving"
        print(f"| {threshold or 'off'} | {start} | {max(e.metrics['wm'] for e in tracked)} | {last['wm']} / {last['ltm']} "
              f"| {last['words']} | {np.median(per_location):.1f} | {len(early)} "
              f"| {ate(sequence, result.trajectory):.3f} | {result.fps:.1f} |")
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


def fidelity() -> None:
    """The cheap figures of the pipeline doc's fidelity section: real excerpts at 640x480,
    synthetic scenarios at 320x240, default parameters unless stated."""
    tum = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tum"
    mono = {"g2o/Baseline": 0.0}
    cases = [
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
    if len(sys.argv) > 2:                      # e.g. "fidelity kidnap": only the cases whose name holds it
        cases = [case for case in cases if sys.argv[2] in case[0]]
    print("| sequence | frames | parameters | frames with a pose | ATE RMSE m | odometry ATE m "
          "| loop closures (appearance / proximity) | largest step error m |")
    print("|---|---|---|---|---|---|---|---|")
    for name, frames, max_frames, overrides in cases:
        sequence, result, events = run(name, frames, (320, 240), max_frames=max_frames, **overrides)
        closures = [e.detection for e in events if isinstance(e, GraphEdge) and e.accepted and e.detection != "odometry"]
        print(f"| {Path(name).name} | {result.frames} | {overrides or 'defaults'} | {len(result.trajectory)} "
              f"| {ate(sequence, result.trajectory) or float('nan'):.4f} "
              f"| {ate(sequence, result.odometry) or float('nan'):.4f} | {closures.count('appearance')} / {closures.count('proximity')} "
              f"| {largest_step_error(sequence, result.trajectory):.3f} |")
    print()


CASES = {"speed": speed, "accuracy": accuracy, "memory": memory, "fidelity": fidelity}

if __name__ == "__main__":
    for case in sys.argv[1:2] or CASES:
        CASES[case]()
