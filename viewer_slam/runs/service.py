"""The run service: a sequence and a run in, a scored run out.

A run is a pipeline (built in or a plugin) with its validated parameters and seed, or an
estimate file replayed over the frames (:mod:`.replay`). Whoever makes runs (``viewslam
record``, a benchmark task) builds them with :func:`build_run` and scores them with
:func:`score_run`, which drives the run with the caller's sinks (a Rerun recorder, a progress
bar), gives each loss its cause, evaluates the trajectory over the frames processed, and
writes the run's report block. So every run is scored by the same chain, whatever watches it.
"""

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.frame import Frame, Sequence
from ..diagnosis import FrameSignals, ImageSignals, SignalRecorder, diagnose_run, measure_image
from ..evaluation.evaluation import Evaluation
from ..pipelines.base import Pipeline, make_pipeline
from ..pipelines.events import Event, FrameTracked
from ..pipelines.run import PipelineRun, Sink, drive
from .replay import estimate_replay
from .run_report import pipeline_report
from .scoring import evaluate_run


@dataclass(frozen=True)
class PipelineSpec:
    """A pipeline run: the registry's ``pipeline`` with ``params``, an instance of its ``Params``
    already validated (never text to parse again), and the ``seed`` of its random choices."""

    pipeline: str
    params: Any
    seed: int = 0


@dataclass(frozen=True)
class EstimateSpec:
    """An estimate run: the trajectory ``file``, read in ``format`` (None: detected)."""

    file: Path
    format: str | None = None


RunSpec = PipelineSpec | EstimateSpec


@dataclass
class ScoredRun:
    """A run and everything said of it: its ``evaluation`` against the groundtruth and its raw
    odometry's (None without groundtruth), the per-frame ``signals`` its losses were diagnosed
    on, the processed frames (``frame_indices``, ``frame_timestamps``) and its report block."""

    run: PipelineRun
    evaluation: Evaluation | None
    odometry_evaluation: Evaluation | None
    signals: FrameSignals
    frame_indices: np.ndarray
    frame_timestamps: np.ndarray
    report: dict[str, Any]


def build_run(spec: RunSpec, sequence: Sequence, *, max_frames: int | None = None, stride: int = 1) -> Pipeline:
    """The pipeline ``spec`` describes, over ``sequence``'s camera; an estimate's replay over the
    frames that ``max_frames`` and ``stride`` select (reading it checks the file and settles its format)."""
    if isinstance(spec, EstimateSpec):
        return estimate_replay(sequence, spec.file, spec.format, max_frames=max_frames, stride=stride)
    return make_pipeline(spec.pipeline, sequence.camera, spec.params, spec.seed)


def score_run(
    sequence: Sequence,
    pipeline: Pipeline,
    name: str,
    *,
    max_frames: int | None = None,
    stride: int = 1,
    sinks: Iterable[Sink] = (),
    frame_sinks: Iterable[Callable[[Frame], None]] = (),
    should_stop: Callable[[], bool] = lambda: False,
    image_signals: Callable[[Frame], ImageSignals] = measure_image,
) -> ScoredRun:
    """Drive ``pipeline`` over ``sequence`` as the run called ``name`` (see
    :func:`~viewer_slam.pipelines.run.drive` for the frames, ``sinks`` and stopping), then
    diagnose its losses and score it over the frames it processed; ``image_signals`` measures
    what each frame shows (a :class:`~viewer_slam.diagnosis.MeasuredImages` shared by the runs
    over the same frames measures each frame once)."""
    signals = SignalRecorder(image_signals)
    processed = _ProcessedFrames()
    run = drive(
        pipeline,
        name,
        sequence,
        max_frames=max_frames,
        stride=stride,
        sinks=[processed, *sinks, signals],
        frame_sinks=[*frame_sinks, signals.frame],
        should_stop=should_stop,
    )
    frame_signals = diagnose_run(run, signals, sequence.groundtruth)
    stamps = np.asarray(processed.timestamps, dtype=np.float64)
    evaluation, odometry_evaluation = evaluate_run(sequence.groundtruth, run, stamps)
    return ScoredRun(
        run,
        evaluation,
        odometry_evaluation,
        frame_signals,
        np.asarray(processed.indices, dtype=int),
        stamps,
        pipeline_report(run, evaluation, odometry_evaluation),
    )


class _ProcessedFrames:
    """The index and stamp of every frame the run tracked (one ``FrameTracked`` each): the
    frames its scores span."""

    def __init__(self) -> None:
        self.indices: list[int] = []
        self.timestamps: list[float] = []

    def __call__(self, event: Event) -> None:
        if isinstance(event, FrameTracked):
            self.indices.append(event.frame_index)
            self.timestamps.append(event.timestamp)
