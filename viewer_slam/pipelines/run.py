"""Feed a sequence through a pipeline, fan its events out to sinks, and summarise the run."""

import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dataset.frame import Frame, Sequence, closing_frames
from ..geometry.trajectory import Trajectory
from .base import Pipeline, make_pipeline
from .edges import EdgeKind
from .events import Event, FrameTracked, GraphEdge, KeyframeAdded, TrackingLost, TrajectoryFinal

Sink = Callable[[Event], None]


@dataclass
class PipelineRun:
    """What a run produced, independent of any evaluation against groundtruth."""

    pipeline: str
    parameters: dict[str, Any]
    seed: int
    source: str = "pipeline"
    tracking_minimum: int | None = None  # the matches or inliers a frame needs, where the pipeline has a minimum
    frames: int = 0
    trajectory: Trajectory = field(default_factory=Trajectory.empty)
    odometry: Trajectory | None = None
    frame_indices: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    keyframes: int = 0
    loop_closures_accepted: int = 0
    loop_closures_rejected: int = 0
    edges: dict[str, int] = field(default_factory=lambda: {kind.value: 0 for kind in EdgeKind})
    edges_by_detection: dict[str, dict[str, int]] = field(default_factory=dict)
    node_frames: list[int] = field(default_factory=list)
    tracking_lost: list[dict[str, Any]] = field(default_factory=list)
    stage_ms_total: dict[str, float] = field(default_factory=dict)
    total_s: float = 0.0
    interrupted: bool = False

    @property
    def fps(self) -> float:
        return self.frames / self.total_s if self.total_s > 0 else 0.0

    @property
    def per_stage_ms(self) -> dict[str, float]:
        """Mean milliseconds per processed frame for each stage."""
        return {stage: total / max(self.frames, 1) for stage, total in self.stage_ms_total.items()}

    def observe(self, event: Event) -> None:
        """Fold one event into the summary (the run's own statistics sink)."""
        if isinstance(event, FrameTracked):
            self.frames += 1
            for stage, ms in event.timings_ms.items():
                self.stage_ms_total[stage] = self.stage_ms_total.get(stage, 0.0) + ms
        elif isinstance(event, KeyframeAdded):
            self.keyframes += 1
            self.node_frames.append(event.frame_index)
        elif isinstance(event, GraphEdge):
            counts = self.edges_by_detection.setdefault(event.detection, {"accepted": 0, "rejected": 0})
            counts["accepted" if event.accepted else "rejected"] += 1
            if event.accepted:
                self.edges[event.kind.value] += 1
            if event.kind == EdgeKind.LOOP:
                if event.accepted:
                    self.loop_closures_accepted += 1
                else:
                    self.loop_closures_rejected += 1
        elif isinstance(event, TrackingLost):
            self.tracking_lost.append(
                {"frame": event.frame_index, "timestamp": event.timestamp, "reason": event.reason}
            )
        elif isinstance(event, TrajectoryFinal):
            self.frame_indices = np.asarray(event.frame_indices, dtype=int)
            self.trajectory = Trajectory(
                event.timestamps, event.poses, event.resumptions if event.resumptions is not None else np.zeros(0)
            )
            if event.odometry_poses is not None:
                self.odometry = Trajectory(event.timestamps, event.odometry_poses)


def run_pipeline(
    sequence: Sequence,
    pipeline_name: str,
    params: Any = None,
    *,
    seed: int = 0,
    max_frames: int | None = None,
    stride: int = 1,
    sinks: Iterable[Sink] = (),
    frame_sinks: Iterable[Callable[[Frame], None]] = (),
    should_stop: Callable[[], bool] = lambda: False,
) -> PipelineRun:
    """Run ``pipeline_name`` over ``sequence`` and return its summary (see :func:`drive`)."""
    pipeline = make_pipeline(pipeline_name, sequence.camera, params, seed)
    return drive(
        pipeline,
        pipeline_name,
        sequence,
        max_frames=max_frames,
        stride=stride,
        sinks=sinks,
        frame_sinks=frame_sinks,
        should_stop=should_stop,
    )


def _shown_ahead(frames: Iterator[Frame], pipeline: Pipeline) -> Iterator[Frame]:
    """``frames`` in order, each shown to ``pipeline.prefetch`` one frame before it is yielded.
    A Ctrl-C while the next frame is read still yields the frame already read, then raises."""
    with closing_frames(frames):
        current = next(frames, None)
        if current is not None:
            pipeline.prefetch(current)
        while current is not None:
            try:
                upcoming = next(frames, None)
            except KeyboardInterrupt:
                yield current
                raise
            if upcoming is not None:
                pipeline.prefetch(upcoming)
            yield current
            current = upcoming


def drive(
    pipeline: Pipeline,
    name: str,
    sequence: Sequence,
    *,
    max_frames: int | None = None,
    stride: int = 1,
    sinks: Iterable[Sink] = (),
    frame_sinks: Iterable[Callable[[Frame], None]] = (),
    should_stop: Callable[[], bool] = lambda: False,
) -> PipelineRun:
    """Feed ``sequence``'s frames through ``pipeline`` as the run called ``name``; its summary.

    ``frame_sinks`` see each frame just before the pipeline does (signal measurements). The
    pipeline is shown each frame (:meth:`Pipeline.prefetch`) one frame ahead: the first two
    before it processes the first, then the next one before it processes each.

    Ctrl-C (KeyboardInterrupt) or ``should_stop()`` ends the frame loop early; the
    pipeline still finishes (final optimisation, final trajectory of the frames seen) and
    the run is marked interrupted, so everything up to that point is kept.
    """
    run = PipelineRun(
        pipeline=name,
        parameters=pipeline.params.model_dump(by_alias=True),
        seed=pipeline.seed,
        source=pipeline.source,
        tracking_minimum=pipeline.params.tracking_minimum(),
    )
    sinks = [run.observe, *sinks]

    def emit(events: list[Event]) -> None:
        for event in events:
            for sink in sinks:
                sink(event)

    start = time.perf_counter()
    with closing_frames(_shown_ahead(sequence.frames(max_frames=max_frames, stride=stride), pipeline)) as frames:
        try:
            for frame in frames:
                for frame_sink in frame_sinks:
                    frame_sink(frame)
                emit(pipeline.process(frame))
                if should_stop():
                    run.interrupted = True
                    break
        except KeyboardInterrupt:
            run.interrupted = True
    emit(pipeline.finish())
    run.total_s = time.perf_counter() - start
    return run
