"""A scripted pipeline on a tiny TUM folder, for tests of the recording whose every number has an
independent value.

The scripted pipeline follows a known circular groundtruth in its own map frame (a fixed
rigid offset from the world), with seeded noise, a lost interval, keyframes, matches, map
points and loop closures.
"""

import os
import signal
import sys
import types
from pathlib import Path

import cv2
import numpy as np
import pytest
from pydantic import Field
from scipy.spatial.transform import Rotation

from viewer_slam.geometry.camera import Camera
from viewer_slam.geometry.se3 import make_pose, pose_to_tq
from viewer_slam.pipelines import base
from viewer_slam.pipelines.base import Pipeline
from viewer_slam.pipelines.edges import EdgeKind
from viewer_slam.pipelines.events import (
    FeatureMatches,
    FrameTracked,
    GraphEdge,
    GraphOptimized,
    KeyframeAdded,
    MapUpdated,
    TrackingLost,
    TrackingRecovered,
    TrackingStatus,
    TrajectoryFinal,
)
from viewer_slam.pipelines.params import PipelineParams
from viewer_slam.record.command import record

CAMERA = Camera(fx=50.0, fy=50.0, cx=31.5, cy=23.5, width=64, height=48)
FRAMES = 40
RATE_HZ = 30.0
START = 1305031100.0
LOST = range(12, 18)  # frames without a pose
NOISE_M = 0.004
MAP_FROM_WORLD = make_pose(Rotation.from_rotvec(np.array([0.1, -0.3, 0.6])).as_matrix(), np.array([0.5, -1.0, 0.2]))


def true_pose(timestamp: float) -> np.ndarray:
    """A camera on a 1 m circle, looking outwards."""
    angle = 0.5 * (timestamp - START)
    position = np.array([np.cos(angle), np.sin(angle), 0.3 * angle])
    return make_pose(Rotation.from_rotvec(np.array([0.0, 0.0, angle])).as_matrix(), position)


def write_tum_folder(folder: Path) -> Path:
    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    rng = np.random.default_rng(7)
    stamps = START + np.arange(FRAMES) / RATE_HZ
    for stamp in stamps:
        rgb = rng.integers(0, 255, (CAMERA.height, CAMERA.width, 3), dtype=np.uint8)
        depth = np.full((CAMERA.height, CAMERA.width), 2.0 * 5000, dtype=np.uint16)
        cv2.imwrite(str(folder / "rgb" / f"{stamp:.6f}.png"), rgb)
        cv2.imwrite(str(folder / "depth" / f"{stamp:.6f}.png"), depth)
    (folder / "rgb.txt").write_text("".join(f"{s:.6f} rgb/{s:.6f}.png\n" for s in stamps))
    (folder / "depth.txt").write_text("".join(f"{s:.6f} depth/{s:.6f}.png\n" for s in stamps))
    gt_stamps = START - 0.5 + np.arange(int((FRAMES / RATE_HZ + 1) * 100)) / 100.0
    t, q = pose_to_tq(np.stack([true_pose(s) for s in gt_stamps]))
    (folder / "groundtruth.txt").write_text(
        "".join(f"{s:.4f} {' '.join(f'{v:.6f}' for v in (*ti, *qi))}\n" for s, ti, qi in zip(gt_stamps, t, q))
    )
    CAMERA.save(folder / "camera.json")
    return folder


class ScriptedParams(PipelineParams):
    keyframe_every: int = Field(5, alias="Scripted/KeyframeEvery", description="frames between keyframes")
    interrupt_at: int = Field(-1, alias="Scripted/InterruptAt", description="frame at which to send SIGINT to itself")


class ScriptedPipeline(Pipeline):
    """Emits what a real pipeline would, computed from the true circle (see module docstring)."""

    name = "scripted"
    Params = ScriptedParams

    def __init__(self, camera, params=None, seed=0):
        super().__init__(camera, params, seed)
        self.rng = np.random.default_rng(seed)
        self.tracked = []
        self.keyframe_poses = []

    def process(self, frame):
        if frame.index == self.params.interrupt_at:
            os.kill(os.getpid(), signal.SIGINT)
        if frame.index in LOST:
            lost = [TrackingLost(frame.index, frame.timestamp, "sensor covered")] if frame.index == LOST[0] else []
            return lost + [FrameTracked(frame.index, frame.timestamp, None, TrackingStatus.LOST, features=3)]
        pose = MAP_FROM_WORLD @ true_pose(frame.timestamp)
        pose[:3, 3] += self.rng.normal(0.0, NOISE_M, 3)
        self.tracked.append((frame.index, frame.timestamp, pose))
        events = []
        if frame.index == LOST[-1] + 1:
            events.append(TrackingRecovered(frame.index, frame.timestamp, "relocalised on keyframe 0"))
        current = self.rng.uniform(0, [self.camera.width, self.camera.height], (20, 2))
        inliers = np.arange(20) < 15
        events.append(FeatureMatches(frame.index, "keyframe", current, current + 1.5, inliers))
        if frame.index % self.params.keyframe_every == 0:
            keyframe_id = len(self.keyframe_poses)
            self.keyframe_poses.append(pose)
            events.append(KeyframeAdded(keyframe_id, frame.index, frame.timestamp, pose))
            points = pose[:3, 3] + self.rng.normal(0.0, 0.3, (200, 3))
            events.append(MapUpdated(frame.index, points, np.full((200, 3), 128, np.uint8)))
            if keyframe_id == 6:
                events.append(
                    GraphEdge(
                        frame.index,
                        6,
                        0,
                        accepted=True,
                        reason="geometric check passed",
                        kind=EdgeKind.LOOP,
                        score=0.9,
                        inliers=40,
                    )
                )
                events.append(
                    GraphEdge(
                        frame.index,
                        6,
                        2,
                        accepted=False,
                        reason="too few inliers",
                        kind=EdgeKind.LOOP,
                        score=0.2,
                        inliers=4,
                    )
                )
                events.append(
                    GraphEdge(
                        frame.index,
                        6,
                        1,
                        accepted=True,
                        reason="geometric check passed",
                        kind=EdgeKind.LOOP,
                        score=0.8,
                        inliers=30,
                    )
                )
            if keyframe_id > 0:  # the odometry edge, and one to a recent keyframe
                events.append(
                    GraphEdge(
                        frame.index,
                        keyframe_id,
                        keyframe_id - 1,
                        accepted=True,
                        reason="odometry",
                        kind=EdgeKind.SEQUENTIAL,
                        inliers=15,
                        detection="predecessor",
                    )
                )
            if keyframe_id > 1:
                events.append(
                    GraphEdge(
                        frame.index,
                        keyframe_id,
                        keyframe_id - 2,
                        accepted=True,
                        reason="matched",
                        kind=EdgeKind.LOCAL,
                        inliers=12,
                        detection="neighbour",
                    )
                )
        status = TrackingStatus.RELOCALISED if frame.index == LOST[-1] + 1 else TrackingStatus.OK
        return events + [
            FrameTracked(
                frame.index,
                frame.timestamp,
                pose,
                status,
                features=40,
                matches=20,
                inliers=15,
                timings_ms={"features": 2.0, "ransac": 1.0},
            )
        ]

    def finish(self):
        indices, stamps, poses = (np.array(values) for values in zip(*self.tracked))
        odometry = poses.copy()
        odometry[:, :3, 3] += np.linspace(0, 0.2, len(poses))[:, None]  # drift that loop closure removed
        keyframes = np.stack(self.keyframe_poses)
        return [
            GraphOptimized(int(indices[-1]), np.arange(len(keyframes)), keyframes, 2.0, 0.1),
            TrajectoryFinal(indices, stamps, poses, odometry),
        ]


def serve_scripted_pipeline(monkeypatch) -> None:
    """`rgbdslam` and `rtabmap` both served by the scripted pipeline."""
    module = types.ModuleType("scripted_pipeline")
    module.PIPELINE = ScriptedPipeline
    monkeypatch.setitem(sys.modules, "scripted_pipeline", module)
    for name in ("rgbdslam", "rtabmap"):
        monkeypatch.setitem(base.PIPELINE_MODULES, name, "scripted_pipeline")


@pytest.fixture
def scripted_pipelines(monkeypatch):
    serve_scripted_pipeline(monkeypatch)


@pytest.fixture(scope="module")
def tum_folder(tmp_path_factory):
    return write_tum_folder(tmp_path_factory.mktemp("tum") / "scripted_circle")


@pytest.fixture(scope="module")
def recorded(tum_folder, tmp_path_factory):
    out = tmp_path_factory.mktemp("out") / "circle.rrd"
    with pytest.MonkeyPatch.context() as monkeypatch:
        serve_scripted_pipeline(monkeypatch)
        result = record(str(tum_folder), out=out, quiet=True)
    return result
