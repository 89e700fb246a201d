"""One benchmark task: a pipeline over a sequence, evaluated, optionally recorded.

``execute_task`` is what the executors ship to worker processes (local or Ray). It never
raises: any error, including running past the task's time limit, becomes a failed
:class:`TaskResult` carrying the error's one-line description, so one bad task cannot
take the others down. A task that records writes its files into a scratch folder of the
worker and returns their bytes with its result: a worker on another machine cannot reach
the driver's ``--out``, so the files travel back the way the result does. A worker on a
machine without the folder the driver planned reads the sequence from its own cache
instead, when the task says how (:class:`SequenceSource`).
"""

import signal
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.catalog import resolve_sequence
from ..dataset.sources import RgbdSequence, open_source
from ..geometry.trajectory import format_tum
from ..pipelines import base
from ..runs.run_report import sequence_block
from ..runs.service import EstimateSpec, PipelineSpec, RunSpec, ScoredRun, build_run, score_run


@dataclass(frozen=True)
class SequenceSource:
    """A catalogue sequence as the benchmark resolved it: its ``name`` (a synthetic scenario or a
    TUM sequence) and, for a scenario, the options it was rendered with. A node that lacks the
    driver's folder resolves it the same way in its own cache: a scenario renders to the same
    bytes on every machine, a TUM sequence must have been downloaded there."""

    name: str
    frames: int | None = None
    resolution: tuple[int, int] = (640, 480)
    seed: int = 0
    first: int | None = None

    def resolve(self, progress: bool = False) -> Path:
        """The sequence's folder here, rendering the scenario into this machine's cache if it is not there."""
        return resolve_sequence(
            self.name,
            frames=self.frames,
            resolution=self.resolution,
            seed=self.seed,
            first=self.first,
            progress=progress,
        )


@dataclass(frozen=True)
class BenchmarkTask:
    """Run ``pipeline`` over the TUM folder ``sequence``, shown in tables as ``name``.

    ``params`` is an instance of the pipeline's ``Params``, validated when the task was planned
    (None: the defaults).
    ``pipeline_modules`` is the pipeline registry the task was planned with, so worker
    processes (which may not share the planner's interpreter) build the same pipelines.
    With ``estimate`` (a trajectory file, read in ``estimate_format`` or a detected one)
    the task replays that estimate as the run ``pipeline`` instead of running a pipeline.
    ``trial`` is the task's index among the runs of one pair that differ only in ``seed``
    (None: the pair runs once). ``source`` says how to find a catalogue sequence where
    ``sequence`` does not exist (another machine); None for a folder given by path.
    """

    name: str
    sequence: Path
    pipeline: str
    params: Any = None
    seed: int = 0
    max_frames: int | None = None
    timeout_s: float | None = None
    recording: Path | None = None
    estimate: Path | None = None
    estimate_format: str | None = None
    trial: int | None = None
    source: SequenceSource | None = None
    pipeline_modules: dict[str, str] = field(default_factory=lambda: dict(base.PIPELINE_MODULES))

    @property
    def label(self) -> str:
        return f"{self.name}/{self.pipeline}" + (f" trial {self.trial}" if self.trial is not None else "")

    @property
    def run(self) -> RunSpec:
        """The task's run, as the run service takes it."""
        if self.estimate is not None:
            return EstimateSpec(self.estimate, self.estimate_format)
        return PipelineSpec(self.pipeline, self.params, self.seed)


def recording_path(recordings: Path, sequence: str, run: str, trial: int | None = None) -> Path:
    """Where a benchmark that records keeps the recording of ``run`` over ``sequence`` (a row's labels),
    of its ``trial`` when the pair runs more than once."""
    return recordings / f"{sequence.replace('/', '_')}.{run}{'' if trial is None else f'.trial{trial}'}.rrd"


@dataclass
class TaskResult:
    """The outcome of one task.

    ``report`` is the per-pipeline block of DESIGN's report (metrics, timing, parameters);
    ``time_span`` the first and last processed frame's timestamps, against which lost
    intervals are read; ``trajectory`` the run's poses as a TUM file holds them;
    ``sequence_block`` the report's description of the sequence (name, path, frames);
    ``trial`` and ``seed`` the task's (``seed`` None for an estimate, which has none);
    ``files`` the recording and the files beside it, by name, on their way from the worker
    to the driver (never cached).
    """

    sequence: str
    pipeline: str
    status: str
    error: str | None = None
    report: dict[str, Any] | None = None
    frames: int = 0
    time_span: tuple[float, float] | None = None
    trajectory: str | None = None
    sequence_block: dict[str, Any] | None = None
    cached: bool = False
    trial: int | None = None
    seed: int | None = None
    files: dict[str, bytes] = field(default_factory=dict, repr=False)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @classmethod
    def failure(cls, task: BenchmarkTask, error: str) -> "TaskResult":
        return cls(
            sequence=task.name,
            pipeline=task.pipeline,
            status="failed",
            error=error,
            trial=task.trial,
            seed=task_seed(task),
        )

    def to_json(self) -> dict[str, Any]:
        """Everything but the files (which the driver writes out on arrival)."""
        return {key: value for key, value in asdict(self).items() if key != "files"}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> "TaskResult":
        span = data.get("time_span")
        return cls(**{**data, "time_span": tuple(span) if span is not None else None})


def task_seed(task: BenchmarkTask) -> int | None:
    """The seed the task's run uses; None for an estimate, which replays a file."""
    return None if task.estimate is not None else task.seed


class TaskTimeout(BaseException):
    """A task ran past its time limit (a BaseException, so pipelines' ``except Exception`` cannot swallow it)."""


@contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`TaskTimeout` inside the block once ``seconds`` have passed.

    Uses SIGALRM, so it only acts in a process's main thread, which is where both the
    process pool and Ray run tasks; elsewhere the block runs unlimited.
    """
    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum, frame):
        raise TaskTimeout(f"timed out after {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def execute_task(task: BenchmarkTask) -> TaskResult:
    """Run, evaluate and (optionally) record one task; errors become a failed result."""
    try:
        with time_limit(task.timeout_s):
            return _run(task)
    except (Exception, TaskTimeout, SystemExit) as error:  # crash isolation: report, never propagate
        message = (
            f"the task called sys.exit({error.code!r})"
            if isinstance(error, SystemExit)
            else " ".join(str(error).split()) or "no message"
        )
        return TaskResult.failure(task, f"{type(error).__name__}: {message}")


def _run(task: BenchmarkTask) -> TaskResult:
    base.PIPELINE_MODULES.update(task.pipeline_modules)
    folder = task.sequence if task.source is None or Path(task.sequence).exists() else task.source.resolve()
    sequence = open_source(folder)
    scored, files = _record(task, folder) if task.recording is not None else (_score(task, sequence), {})
    frames = scored.run.frames
    if frames == 0:
        raise ValueError(f"{task.sequence}: no frames")
    time_span = (float(sequence.timestamps[0]), float(sequence.timestamps[frames - 1]))
    # The driver reads the sequence at its own path (a comparison opens its groundtruth there).
    block = (
        {**sequence_block(sequence), "path": str(task.sequence)}
        if folder != task.sequence
        else sequence_block(sequence)
    )
    return TaskResult(
        sequence=task.name,
        pipeline=task.pipeline,
        status="ok",
        report=_plain(scored.report),
        frames=frames,
        time_span=time_span,
        trajectory=format_tum(scored.run.trajectory),
        sequence_block=block,
        trial=task.trial,
        seed=task_seed(task),
        files=files,
    )


def _score(task: BenchmarkTask, sequence: RgbdSequence) -> ScoredRun:
    """The task's run over ``sequence``, with no sink but the scoring's own."""
    run = build_run(task.run, sequence, max_frames=task.max_frames)
    return score_run(sequence, run, task.pipeline, max_frames=task.max_frames)


def _record(task: BenchmarkTask, folder: Path) -> tuple[ScoredRun, dict[str, bytes]]:
    """The task's run over ``folder`` recorded as `viewslam record` records it, into a scratch folder of
    this worker; with the bytes of the recording and of the report and trajectory beside it, by file name."""
    from ..record.options import FrameSelection  # Rerun is loaded only by tasks that record
    from ..record.session import record_runs

    assert task.recording is not None  # only a task that records is recorded
    with tempfile.TemporaryDirectory(prefix="viewslam-task-") as scratch:
        recorded = record_runs(
            str(folder),
            {task.pipeline: task.run},
            Path(scratch) / task.recording.name,
            frames=FrameSelection(task.max_frames),
        )
        files = {path.name: path.read_bytes() for path in recorded.written}
    return recorded.scored[task.pipeline], files


def _plain(value: Any) -> Any:
    """The report with numpy scalars and arrays turned into JSON types (it crosses processes and the cache)."""
    if isinstance(value, dict):
        return {str(key): _plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value
