"""ATE + RPE (Δ = 1 frame, every consecutive pair) on 20,000 poses: viewslam against evo.

Both sides start from the same two in-memory trajectories whose stamps differ by a few
milliseconds, so both associate, align (rigid Horn/Umeyama), and compute the ATE and the
RPE translation and rotation. Prints the median wall time of each, the ratio, and checks
that the numbers agree to 1e-9 relative.

    python -m benchmarks.evaluate [--poses N] [--repeats R]
"""

import argparse
import copy
import statistics
import time
from collections.abc import Callable

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np
from evo.core import metrics, sync
from evo.core.trajectory import PoseTrajectory3D
from scipy.spatial.transform import Rotation

from viewer_slam.evaluation import evaluate
from viewer_slam.evaluation.rpe import DeltaUnit
from viewer_slam.geometry.se3 import make_pose
from viewer_slam.geometry.trajectory import Trajectory

from . import lab


def trajectories(count: int, seed: int) -> tuple[Trajectory, Trajectory]:
    """A 30 Hz random walk and a noisy estimate of it whose stamps jitter by up to 4 ms."""
    rng = np.random.default_rng(seed)
    stamps = 1000.0 + np.arange(count) / 30.0
    rotations = Rotation.from_rotvec(np.cumsum(rng.normal(scale=0.01, size=(count, 3)), axis=0)).as_matrix()
    positions = np.cumsum(rng.normal(scale=0.01, size=(count, 3)), axis=0)
    noise = Rotation.from_rotvec(rng.normal(scale=0.005, size=(count, 3))).as_matrix()
    groundtruth = Trajectory(stamps, make_pose(rotations, positions))
    estimate = Trajectory(
        stamps + rng.uniform(-0.004, 0.004, count),
        make_pose(rotations @ noise, positions + rng.normal(scale=0.005, size=(count, 3))),
    )
    return groundtruth, estimate


def ours(groundtruth: Trajectory, estimate: Trajectory) -> dict[str, float]:
    evaluation = evaluate(groundtruth, estimate, delta=1, delta_unit=DeltaUnit.FRAMES)
    return {
        "pairs": len(evaluation.pairs[0]),
        "ate": lab.rmse(evaluation.ate),
        "rpe_trans": lab.rmse(evaluation.rpe_trans),
        "rpe_rot": lab.rmse(evaluation.rpe_rot),
    }


def evos(reference: PoseTrajectory3D, estimate: PoseTrajectory3D) -> dict[str, float]:
    reference, estimate = sync.associate_trajectories(reference, estimate, max_diff=0.02)
    result = {"pairs": reference.num_poses}
    for name, relation in (
        ("rpe_trans", metrics.PoseRelation.translation_part),
        ("rpe_rot", metrics.PoseRelation.rotation_angle_deg),
    ):
        rpe = metrics.RPE(relation, delta=1, delta_unit=metrics.Unit.frames, all_pairs=True)
        rpe.process_data((reference, estimate))
        result[name] = rpe.get_statistic(metrics.StatisticsType.rmse)
    aligned = copy.deepcopy(estimate)
    aligned.align(reference)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((reference, aligned))
    result["ate"] = ape.get_statistic(metrics.StatisticsType.rmse)
    return result


def median_seconds(function: Callable[[], dict[str, float]], repeats: int) -> tuple[float, dict[str, float]]:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.evaluate", description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)

    groundtruth, estimate = trajectories(args.poses, seed=0)
    evo_reference = PoseTrajectory3D(poses_se3=list(groundtruth.poses), timestamps=groundtruth.timestamps)
    evo_estimate = PoseTrajectory3D(poses_se3=list(estimate.poses), timestamps=estimate.timestamps)

    our_time, our_numbers = median_seconds(lambda: ours(groundtruth, estimate), args.repeats)
    evo_time, evo_numbers = median_seconds(lambda: evos(evo_reference, evo_estimate), args.repeats)

    print(f"{args.poses} poses, median of {args.repeats} runs")
    print(f"viewslam: {our_time * 1000:9.1f} ms")
    print(f"evo:      {evo_time * 1000:9.1f} ms")
    print(f"ratio:    {evo_time / our_time:9.1f}x")
    equal = our_numbers["pairs"] == evo_numbers["pairs"]
    for name in ("ate", "rpe_trans", "rpe_rot"):
        relative = abs(our_numbers[name] - evo_numbers[name]) / abs(evo_numbers[name])
        equal &= relative <= 1e-9
        print(
            f"{name:9s} viewslam {our_numbers[name]:.12f}  evo {evo_numbers[name]:.12f}  "
            f"relative difference {relative:.1e}"
        )
    print(f"pairs     viewslam {our_numbers['pairs']}  evo {evo_numbers['pairs']}")
    print("numbers equal" if equal else "NUMBERS DIFFER")
    return 0 if equal else 1


if __name__ == "__main__":
    lab.main_of(main)
