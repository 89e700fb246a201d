"""A peer baseline measured in the same run: Open3D's RGB-D odometry beside viewslam's pipelines.

    python -m benchmarks.peer [--sequence SPEC] [--frames N] [--pipelines rgbdslam rtabmap]
                              [--param KEY=VALUE ...] [--config FILE.toml]

Open3D's frame-to-frame RGB-D odometry (the hybrid photometric and geometric term, its
default) runs over exactly the frames each pipeline gets, recording off; the pipelines run
through the run service, as ``viewslam record`` runs them, with its parameters. Every figure comes
with its ratio to Open3D's, and ratios measured in one run on one machine hold across
machines where absolute frames per second do not. CPU frames per second use the process's
CPU time, which other load on a shared machine does not inflate. Each pipeline's mean
milliseconds per frame by stage (its report's ``timing``) follow the table.

Each method first runs untimed over the sequence's first WARM_UP_FRAMES frames: what it does
once per process, loading the pipelines' compiled code from numba's cache, Open3D's and
OpenCV's own first-call set-up, stays outside the timed run, as Open3D's import does. A
pipeline's run is otherwise unchanged: its warm-up is a pipeline of its own, discarded.

Run with the defaults on a TUM excerpt that docs/pipelines.md shows (the 200-frame and the
87-frame fr1/rpy), it writes the table there (figure block ``peer-<folder>``), stamped with
the command, the machine, the date and the load before and after: too costly for the test
suite, so never re-run there.
"""

import argparse
import os
import time
from pathlib import Path

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.sources import RgbdSequence, open_source
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.open3d_loader import import_open3d
from viewer_slam.runs.run_report import versions

from . import lab
from .figures import REPO, TUM, invocation, stamp, write_block

DEFAULT_SEQUENCE = str(TUM / "rgbd_dataset_freiburg1_rpy_200")
DEFAULT_PIPELINES = ["rgbdslam", "rtabmap"]
DEPTH_TRUNC_M = 4.0
# Enough frames that every method compares two (rgbdslam three nodes), so that each has
# called its compiled code once.
WARM_UP_FRAMES = 3
DOCUMENT = REPO / "docs" / "pipelines.md"
# TUM folders whose figures docs/pipelines.md shows, by folder name, and their block.
SEQUENCE_BLOCKS = {
    "rgbd_dataset_freiburg1_rpy_200": "peer-fr1-rpy-200",
    "rgbd_dataset_freiburg1_rpy": "peer-fr1-rpy-87",
}


def open3d_odometry(sequence, max_frames: int | None) -> tuple[Trajectory, float, float]:
    """Open3D's odometry chained frame to frame: the trajectory, wall and CPU seconds."""
    o3d = import_open3d()
    odometry = o3d.pipelines.odometry
    camera = sequence.camera
    intrinsic = o3d.camera.PinholeCameraIntrinsic(
        camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy
    )
    jacobian, option = odometry.RGBDOdometryJacobianFromHybridTerm(), odometry.OdometryOption()
    stamps, poses, previous = [], [], None
    wall, cpu = time.perf_counter(), lab.process_cpu_s()
    for frame in sequence.frames(max_frames=max_frames):
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.geometry.Image(np.ascontiguousarray(frame.rgb)),
            o3d.geometry.Image(frame.depth.astype(np.float32)),
            depth_scale=1.0,
            depth_trunc=DEPTH_TRUNC_M,
            convert_rgb_to_intensity=True,
        )
        if previous is None:
            pose = np.eye(4)
        else:
            # The motion maps the current frame's points into the previous frame's.
            success, previous_from_current, _ = odometry.compute_rgbd_odometry(
                rgbd, previous, intrinsic, np.eye(4), jacobian, option
            )
            pose = poses[-1] @ (previous_from_current if success else np.eye(4))
        stamps.append(frame.timestamp)
        poses.append(pose)
        previous = rgbd
    return Trajectory(np.array(stamps), np.stack(poses)), time.perf_counter() - wall, lab.process_cpu_s() - cpu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.peer", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--sequence", default=DEFAULT_SEQUENCE, help="TUM folder or synthetic scenario name")
    parser.add_argument("--frames", type=int, default=None, help="the first N frames")
    parser.add_argument("--pipelines", nargs="+", default=DEFAULT_PIPELINES)
    lab.add_parameter_options(parser)
    args = parser.parse_args(argv)
    load = os.getloadavg()[0]
    specs = lab.pipeline_specs(args.pipelines, args)
    sequence = open_source(args.sequence)
    frames = min(len(sequence), args.frames or len(sequence))
    print(f"sequence {sequence.name}: {frames} frames, {sequence.camera.width}x{sequence.camera.height}")

    open3d_odometry(sequence, WARM_UP_FRAMES)
    trajectory, wall_s, cpu_s = open3d_odometry(sequence, args.frames)
    peer_ate = _ate_cm(sequence, trajectory)
    peer_fps, peer_cpu_fps = frames / wall_s, frames / cpu_s
    rows = [
        "| method | ATE RMSE | odometry ATE | frames/s, wall (× Open3D) | frames/s, CPU time (× Open3D) |",
        "|---|---|---|---|---|",
        f"| Open3D RGB-D odometry | {peer_ate:.2f} cm | {peer_ate:.2f} cm | {peer_fps:.1f} (1.00) | "
        f"{peer_cpu_fps:.1f} (1.00) |",
    ]
    print("\n".join(rows))
    stages = []
    for name, spec in specs.items():
        lab.run(sequence, spec, name, max_frames=WARM_UP_FRAMES)
        cpu = lab.process_cpu_s()
        run = lab.run(sequence, spec, name, max_frames=args.frames).run
        cpu_fps = run.frames / (lab.process_cpu_s() - cpu)
        ate, odometry_ate = (_ate_cm(sequence, trajectory) for trajectory in (run.trajectory, run.odometry))
        rows.append(
            f"| {name} | {ate:.2f} cm | {odometry_ate:.2f} cm | {run.fps:.1f} ({run.fps / peer_fps:.2f}) | "
            f"{cpu_fps:.1f} ({cpu_fps / peer_cpu_fps:.2f}) |"
        )
        stages.append(f"{name}: " + ", ".join(f"`{stage}` {ms:.1f}" for stage, ms in run.per_stage_ms.items()))
        print(rows[-1], flush=True)
    print("\n".join(stages))
    block = SEQUENCE_BLOCKS.get(Path(args.sequence).resolve().name)
    if block and args.frames is None and not args.param and not args.config and args.pipelines == DEFAULT_PIPELINES:
        document(block, invocation(parser.prog, lab.arguments(argv)), load, rows, stages)
    return 0


def document(block: str, command: str, load: float, rows: list[str], stages: list[str]) -> None:
    """The table and the stage times into docs/pipelines.md, stamped with ``command``."""
    installed = versions()
    text = (
        f"{stamp(command)} Load average {load:.1f} before the run, {os.getloadavg()[0]:.1f} after; "
        f"OpenCV {installed['opencv']}, GTSAM {installed['gtsam']}, Open3D {installed['open3d']}.\n\n"
        + "\n".join(rows)
        + "\n\nMean milliseconds per frame by stage, by the wall clock (the report's `timing`; stages "
        "that run on threads of their own overlap): " + "; ".join(stages) + "."
    )
    write_block(DOCUMENT, block, text)


def _ate_cm(sequence: RgbdSequence, trajectory: Trajectory | None) -> float:
    """ATE RMSE in cm, NaN for a run without a pose."""
    return 100 * lab.ate_rmse(sequence.groundtruth, trajectory)


if __name__ == "__main__":
    lab.main_of(main)
