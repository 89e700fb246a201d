"""Trajectories written as KITTI and EuRoC files, in full precision, for tests that read them back."""

from pathlib import Path

import numpy as np

from viewer_slam.geometry.se3 import pose_to_tq
from viewer_slam.geometry.trajectory import Trajectory


def write_kitti(path: Path, trajectory: Trajectory) -> Path:
    """3x4 ``[R | t]`` row-major per line, full double precision."""
    path.write_text("".join(" ".join(f"{v:.17g}" for v in pose[:3].reshape(-1)) + "\n" for pose in trajectory.poses))
    return path


def nanoseconds(stamps: np.ndarray) -> list[int]:
    return [round(stamp * 1e9) for stamp in stamps]


def write_euroc(
    path: Path, trajectory: Trajectory, header: str = "#timestamp [ns],tx,ty,tz,qw,qx,qy,qz", extra_columns: int = 0
) -> Path:
    t, q = pose_to_tq(trajectory.poses)
    rows = [
        ",".join([str(ns), *(f"{v:.17g}" for v in (*p, r[3], r[0], r[1], r[2])), *["0.5"] * extra_columns])
        for ns, p, r in zip(nanoseconds(trajectory.timestamps), t, q)
    ]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path
