"""The zero-motion baseline: a camera that never moves, as a viewslam pipeline plugin."""

import numpy as np
from pydantic import Field

from viewer_slam.pipelines.base import Pipeline
from viewer_slam.pipelines.events import FrameTracked, TrackingLost, TrackingRecovered, TrackingStatus, TrajectoryFinal
from viewer_slam.pipelines.params import PipelineParams


class StationaryParams(PipelineParams):
    report_every: int = Field(1, ge=1, description="give a pose on every N-th frame only; the frames between are lost")


class StationaryPipeline(Pipeline):
    """Every frame at the identity pose: the score of not tracking at all."""

    name = "stationary"
    Params = StationaryParams

    def __init__(self, camera, params=None, seed=0):
        super().__init__(camera, params, seed)
        self.indices, self.stamps = [], []
        self.lost = False

    def process(self, frame):
        tracked = frame.index % self.params.report_every == 0
        events = []
        if tracked:
            self.indices.append(frame.index)
            self.stamps.append(frame.timestamp)
            if self.lost:
                events.append(TrackingRecovered(frame.index, frame.timestamp, "pose reported again"))
        elif not self.lost:
            events.append(TrackingLost(frame.index, frame.timestamp, "frame skipped by report_every"))
        self.lost = not tracked
        status = TrackingStatus.OK if tracked else TrackingStatus.LOST
        return [FrameTracked(frame.index, frame.timestamp, np.eye(4) if tracked else None, status), *events]

    def finish(self):
        poses = np.broadcast_to(np.eye(4), (len(self.indices), 4, 4)).copy()
        return [TrajectoryFinal(np.array(self.indices, dtype=int), np.array(self.stamps), poses)]
