from pathlib import Path

import numpy as np
import pytest
from pydantic import Field

from viewer_slam.dataset.frame import Frame
from viewer_slam.errors import InputError
from viewer_slam.geometry.camera import Camera
from viewer_slam.pipelines import base
from viewer_slam.pipelines.base import Pipeline, make_pipeline
from viewer_slam.pipelines.edges import EdgeKind
from viewer_slam.pipelines.events import (
    FrameTracked,
    GraphEdge,
    KeyframeAdded,
    TrackingLost,
    TrackingStatus,
    TrajectoryFinal,
)
from viewer_slam.pipelines.params import PipelineParams
from viewer_slam.pipelines.run import drive, run_pipeline

CAMERA = Camera(fx=100, fy=100, cx=16, cy=12, width=32, height=24)


class CountingParams(PipelineParams):
    lost_after: int = Field(1000, description="frames after which tracking is lost for good")


class CountingPipeline(Pipeline):
    """Moves 1 cm per frame, a keyframe every 5 frames, lost from `lost_after` on."""

    name = "counting"
    Params = CountingParams

    def __init__(self, camera, params=None, seed=0):
        super().__init__(camera, params, seed)
        self.tracked = []

    def process(self, frame):
        events = []
        if frame.index >= self.params.lost_after:
            if frame.index == self.params.lost_after:
                events.append(TrackingLost(frame.index, frame.timestamp, "test"))
            return events + [
                FrameTracked(frame.index, frame.timestamp, None, TrackingStatus.LOST, timings_ms={"features": 2.0})
            ]
        pose = np.eye(4)
        pose[0, 3] = 0.01 * frame.index
        self.tracked.append((frame.index, frame.timestamp, pose))
        if frame.index % 5 == 0:
            events.append(KeyframeAdded(frame.index // 5, frame.index, frame.timestamp, pose))
        if frame.index == 7:
            events.append(GraphEdge(frame.index, 1, 0, accepted=False, reason="test", kind=EdgeKind.LOOP))
        return events + [
            FrameTracked(frame.index, frame.timestamp, pose, TrackingStatus.OK, timings_ms={"features": 1.0})
        ]

    def finish(self):
        indices, stamps, poses = zip(*self.tracked)
        return [TrajectoryFinal(np.array(indices), np.array(stamps), np.stack(poses))]


class FakeSequence:
    name = "fake"
    path = Path("fake")
    camera = CAMERA
    groundtruth = None

    def __init__(self, n, interrupt_at=None):
        self.n = n
        self.interrupt_at = interrupt_at

    def __len__(self):
        return self.n

    def frames(self, max_frames=None, stride=1):
        for yielded, index in enumerate(range(0, self.n, stride)):
            if max_frames is not None and yielded >= max_frames:
                return
            if index == self.interrupt_at:
                raise KeyboardInterrupt
            yield Frame(index, 100.0 + index / 30, np.zeros((24, 32, 3), np.uint8), np.zeros((24, 32), np.float32))


@pytest.fixture(autouse=True)
def counting_pipeline(monkeypatch):
    monkeypatch.setitem(base.PIPELINE_MODULES, "counting", __name__)


PIPELINE = CountingPipeline


def test_run_summarises_the_events():
    seen = []
    run = run_pipeline(FakeSequence(20), "counting", CountingParams(lost_after=15), sinks=[seen.append])
    assert run.frames == 20
    assert run.keyframes == 3
    assert (run.loop_closures_accepted, run.loop_closures_rejected) == (0, 1)
    assert run.tracking_lost == [{"frame": 15, "timestamp": 100.5, "reason": "test"}]
    assert len(run.trajectory) == 15
    assert run.frame_indices.tolist() == list(range(15))
    assert run.per_stage_ms == {"features": pytest.approx((15 * 1.0 + 5 * 2.0) / 20)}
    assert run.parameters == {"lost_after": 15}
    assert sum(isinstance(event, FrameTracked) for event in seen) == 20
    assert isinstance(seen[-1], TrajectoryFinal)
    assert not run.interrupted


def test_stride_and_max_frames_keep_sequence_indices():
    run = run_pipeline(FakeSequence(30), "counting", stride=3, max_frames=4)
    assert run.frame_indices.tolist() == [0, 3, 6, 9]


def test_interrupt_keeps_what_was_processed():
    run = run_pipeline(FakeSequence(30, interrupt_at=12), "counting")
    assert run.interrupted
    assert run.frames == 12
    assert len(run.trajectory) == 12


class PrefetchingPipeline(CountingPipeline):
    """Records the order of the calls it gets."""

    def __init__(self, camera, params=None, seed=0):
        super().__init__(camera, params, seed)
        self.calls = []

    def prefetch(self, frame):
        self.calls.append(("prefetch", frame.index))

    def process(self, frame):
        self.calls.append(("process", frame.index))
        return super().process(frame)


@pytest.mark.parametrize("interrupt_at", [None, 3])
def test_each_frame_is_shown_one_frame_ahead_and_every_frame_read_is_processed(interrupt_at):
    pipeline = PrefetchingPipeline(CAMERA)
    run = drive(pipeline, "counting", FakeSequence(4, interrupt_at=interrupt_at))
    expected = [("prefetch", 0), ("prefetch", 1), ("process", 0), ("prefetch", 2), ("process", 1)]
    if interrupt_at is None:
        expected += [("prefetch", 3), ("process", 2), ("process", 3)]
    else:  # Ctrl-C while frame 3 is read: frame 2, already read, is still processed
        expected += [("process", 2)]
    assert pipeline.calls == expected and run.interrupted == (interrupt_at is not None)


def test_should_stop_ends_the_loop():
    run = run_pipeline(FakeSequence(30), "counting", should_stop=lambda: True)
    assert run.interrupted and run.frames == 1


def test_unknown_pipeline_lists_the_valid_ones():
    with pytest.raises(InputError, match="unknown pipeline 'nope'; valid: rgbdslam, rtabmap"):
        make_pipeline("nope", CAMERA)
