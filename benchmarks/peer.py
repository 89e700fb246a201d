"""A peer baseline measured in the same run: Open3D's RGB-D odometry beside viewslam's pipelines.

    python benchmarks/peer.py [--sequence SPEC] [--frames N] [--pipelines rgbdslam rtabmap] [--param KEY=VALUE]

Open3D's frame-to-frame RGB-D odometry (the hybrid photometric and geometric term, its
default) runs over exactly the frames each pipeline gets, recording off. Every figure comes
with its ratio to Open3D's, and ratios measured in one run on one machine hold across
machines where absolute frames per second do not. CPU frames per second use the process's
CPU time, which other load on a shared machine does not inflate.
"""

import argparse
import os
import time
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.sources import open_source
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.open3d_loader import import_open3d
from viewer_slam.pipelines.base import pipeline_class
from viewer_slam.pipelines.params import resolve_params
from viewer_slam.pipelines.run import run_pipeline

DEFAULT_SEQUENCE = str(Path(__file__).resolve().parents[1].parent / "shared/data/tum/rgbd_dataset_freiburg1_rpy_200")
DEPTH_TRUNC_M = 4.0


def process_cpu_s() -> float:
    times = os.times()
    return times.user + times.system


def open3d_odometry(sequence, max_frames: int | None) -> tuple[Trajectory, float, float]:
    """Open3D's odometry chained frame to frame: the trajectory, wall and CPU seconds."""
    o3d = import_open3d()
    odometry = o3d.pipelines.odometry
    camera = sequence.camera
    intrinsic = o3d.camera.PinholeCameraIntrinsic(camera.width, camera.height, camera.fx, camera.fy,
                                                  camera.cx, camera.cy)
    jacobian, option = odometry.RGBDOdometryJacobianFromHybridTerm(), odometry.OdometryOption()
    stamps, poses, previous = [], [], None
    wall, cpu = time.perf_counter(), process_cpu_s()
    for frame in sequence.frames(max_frames=max_frames):
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.geometry.Image(np.ascontiguousarray(frame.rgb)), o3d.geometry.Image(frame.depth.astype(np.float32)),
            depth_scale=1.0, depth_trunc=DEPTH_TRUNC_M, convert_rgb_to_intensity=True)
        if previous is None:
            pose = np.eye(4)
        else:
            # The motion maps the current frame's points into the previous frame's.
            success, previous_from_current, _ = odometry.compute_rgbd_odometry(
                rgbd, previous, intrinsic, np.eye(4), jacobian, option)
            pose = poses[-1] @ (previous_from_current if success else np.eye(4))
        stamps.append(frame.timestamp)
        poses.append(pose)
        previous = rgbd
    return Trajectory(np.array(stamps), np.stack(poses)), time.perf_counter() - wall, process_cpu_s() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sequence", default=DEFAULT_SEQUENCE, help="TUM folder or synthetic scenario name")
    parser.add_argument("--frames", type=int, default=None, help="the first N frames")
    parser.add_argument("--pipelines", nargs="+", default=["rgbdslam", "rtabmap"])
    parser.add_argument("--param", action="append", default=[],
                        help="KEY=VALUE for the pipelines that have KEY, as `viewslam record --param`")
    args = parser.parse_args()
    params = resolve_params({name: pipeline_class(name).Params for name in args.pipelines}, args.param)
    sequence = open_source(args.sequence)
    frames = min(len(sequence), args.frames or len(sequence))
    print(f"sequence {sequence.name}: {frames} frames, {sequence.camera.width}x{sequence.camera.height}")

    trajectory, wall_s, cpu_s = open3d_odometry(sequence, args.frames)
    peer_ate = _ate_cm(sequence, trajectory) / 100
    peer_fps, peer_cpu_fps = frames / wall_s, frames / cpu_s
    print("| method | ATE RMSE cm | odometry ATE cm | ATE / Open3D | fps (wall) | fps / Open3D | fps (CPU) | "
          "CPU fps / Open3D |")
    print("|---|---|---|---|---|---|---|---|")
    print(f"| Open3D RGB-D odometry | {100 * peer_ate:.2f} | {100 * peer_ate:.2f} | 1.00 | {peer_fps:.1f} | 1.00 | "
          f"{peer_cpu_fps:.1f} | 1.00 |")
    for name in args.pipelines:
        cpu = process_cpu_s()
        run = run_pipeline(sequence, name, params[name], seed=0, max_frames=args.frames)
        cpu_fps = run.frames / (process_cpu_s() - cpu)
        ate, odometry_ate = (_ate_cm(sequence, trajectory) for trajectory in (run.trajectory, run.odometry))
        print(f"| {name} | {ate:.2f} | {odometry_ate:.2f} | {ate / (100 * peer_ate):.2f} | {run.fps:.1f} | "
              f"{run.fps / peer_fps:.2f} | {cpu_fps:.1f} | {cpu_fps / peer_cpu_fps:.2f} |", flush=True)


def _ate_cm(sequence, trajectory: Trajectory) -> float:
    """ATE RMSE in cm, NaN for a run without a pose."""
    evaluation = evaluate(sequence.groundtruth, trajectory) if len(trajectory) else None
    return float("nan") if evaluation is None or evaluation.ate is None else 100 * evaluation.ate.stats()["rmse"]


if __name__ == "__main__":
    main()
