"""A scripted pipeline and tiny TUM folders for the benchmark tests.

The pipeline reports the groundtruth pose of each frame (the same function of time that
writes the folders' groundtruth.txt) plus a fixed offset per frame, loses tracking over a
chosen stretch of frames, and can be told to fail in the ways a real task can: raise,
kill its worker process, or hang. Its error can grow with the run's seed, so trials differ.
It lives in an importable module because worker processes (the pool's and Ray's) import
pipelines by module name.

On a test's Ray cluster, a node started with ``FAKE_PIPELINE_MARKERS`` (a folder) leaves a
file there for every run it starts, named by the worker's process id; with
``FAKE_PIPELINE_DOOMED`` set too, ``fail="hang_where_doomed"`` hangs there (and only there),
so that the test can take the node down in the middle of a task.
"""

import os
import sys
import time
from pathlib import Path
from typing import Literal

import cv2
import numpy as np
from pydantic import Field
from scipy.spatial.transform import Rotation

from viewer_slam.geometry.camera import Camera
from viewer_slam.geometry.se3 import make_pose, pose_to_tq
from viewer_slam.pipelines.base import Pipeline
from viewer_slam.pipelines.events import FrameTracked, TrackingLost, TrackingRecovered, TrackingStatus, TrajectoryFinal
from viewer_slam.pipelines.params import PipelineParams

MODULE = __name__
FRAME_RATE_HZ = 30.0
START_S = 1000.0


def groundtruth_pose(t: float) -> np.ndarray:
    """A camera walking along x while turning slowly about y."""
    dt = t - START_S
    return make_pose(
        Rotation.from_rotvec(np.array([0.0, 0.2 * dt, 0.0])).as_matrix(), np.array([0.5 * dt, 0.1 * np.sin(dt), 0.0])
    )


def write_tum_folder(folder: Path, frames: int = 30, size: tuple[int, int] = (32, 24)) -> Path:
    """A valid TUM RGB-D folder: PNG colour/depth, listings, camera.json and a groundtruth pose per frame."""
    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    width, height = size
    stamps = START_S + np.arange(frames) / FRAME_RATE_HZ
    rgb_lines, depth_lines = ["# colour"], ["# depth"]
    for k, stamp in enumerate(stamps):
        cv2.imwrite(str(folder / "rgb" / f"{stamp:.6f}.png"), np.full((height, width, 3), k % 256, np.uint8))
        cv2.imwrite(str(folder / "depth" / f"{stamp:.6f}.png"), np.full((height, width), 5000, np.uint16))
        rgb_lines.append(f"{stamp:.6f} rgb/{stamp:.6f}.png")
        depth_lines.append(f"{stamp:.6f} depth/{stamp:.6f}.png")
    (folder / "rgb.txt").write_text("\n".join(rgb_lines) + "\n")
    (folder / "depth.txt").write_text("\n".join(depth_lines) + "\n")
    truth = []
    for t in stamps:
        pose = groundtruth_pose(t)
        qx, qy, qz, qw = pose_to_tq(pose)[1]
        truth.append(f"{t:.4f} {pose[0, 3]:.6f} {pose[1, 3]:.6f} {pose[2, 3]:.6f} {qx:.6f} {qy:.6f} {qz:.6f} {qw:.6f}")
    (folder / "groundtruth.txt").write_text("\n".join(truth) + "\n")
    Camera(40.0, 40.0, width / 2 - 0.5, height / 2 - 0.5, width, height).save(folder / "camera.json")
    return folder


class FakeParams(PipelineParams):
    offset_m: float = Field(0.01, description="Constant position error added to every pose.")
    wobble_m: float = Field(0.0, description="Amplitude of a position error alternating frame by frame.")
    wobble_per_seed_m: float = Field(0.0, description="Added to the wobble per unit of the run's seed.")
    lost_from: int = Field(-1, description="First frame without a pose (-1: never lost).")
    lost_until: int = Field(-1, description="First frame with a pose again (-1: never recovers).")
    fail: Literal["", "raise", "exit", "sys.exit", "hang", "hang_where_doomed"] = Field(
        "", description="How to fail on the first frame."
    )


class FakePipeline(Pipeline):
    name = "fake"
    Params = FakeParams

    def __init__(self, camera, params=None, seed=0):
        super().__init__(camera, params, seed)
        self.indices, self.stamps, self.poses = [], [], []
        self.lost = False

    def process(self, frame):
        if frame.index == 0 and os.environ.get("FAKE_PIPELINE_MARKERS"):
            (Path(os.environ["FAKE_PIPELINE_MARKERS"]) / f"{os.getpid()}-{time.monotonic_ns()}").touch()
        if self.params.fail == "hang_where_doomed" and os.environ.get("FAKE_PIPELINE_DOOMED"):
            time.sleep(3600)
        if self.params.fail == "raise":
            raise RuntimeError("scripted failure")
        if self.params.fail == "exit":
            os._exit(3)
        if self.params.fail == "sys.exit":
            sys.exit(5)
        if self.params.fail == "hang":
            time.sleep(3600)
        p = self.params
        lost = p.lost_from >= 0 and frame.index >= p.lost_from and (p.lost_until < 0 or frame.index < p.lost_until)
        events = []
        if lost and not self.lost:
            events.append(TrackingLost(frame.index, frame.timestamp, "scripted loss"))
        if self.lost and not lost:
            events.append(TrackingRecovered(frame.index, frame.timestamp, "scripted recovery"))
        self.lost = lost
        pose = None
        if not lost:
            pose = groundtruth_pose(frame.timestamp)
            pose[:3, 3] += p.offset_m + (p.wobble_m + p.wobble_per_seed_m * self.seed) * (-1) ** frame.index
            self.indices.append(frame.index)
            self.stamps.append(frame.timestamp)
            self.poses.append(pose)
        status = TrackingStatus.LOST if lost else TrackingStatus.OK
        return [FrameTracked(frame.index, frame.timestamp, pose, status, timings_ms={"features": 1.0}), *events]

    def finish(self):
        poses = np.array(self.poses).reshape(-1, 4, 4)
        return [TrajectoryFinal(np.array(self.indices, dtype=int), np.array(self.stamps), poses)]


PIPELINE = FakePipeline


def recorded_report(folder: Path) -> Path:
    """The report (``a.json``, its trajectory beside it) of a 4-frame run of this pipeline in ``folder``."""
    from viewer_slam.cli import main
    from viewer_slam.pipelines import base

    saved = base.PIPELINE_MODULES.get("fake")
    base.PIPELINE_MODULES["fake"] = MODULE
    try:
        sequence = write_tum_folder(folder / "tiny", frames=4)
        assert main(["record", str(sequence), "--pipeline", "fake", "--out", str(folder / "a.rrd"), "--quiet"]) == 0
    finally:
        if saved is None:
            del base.PIPELINE_MODULES["fake"]
        else:
            base.PIPELINE_MODULES["fake"] = saved
    return folder / "a.json"
