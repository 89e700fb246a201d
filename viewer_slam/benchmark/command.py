"""``viewslam benchmark`` as a library function: sequences × runs planned, run on an executor,
and written as results, report and charts, in one call that goes down the layers once."""

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..atomic import check_writable, exclusive, refuse_inputs_as_outputs
from ..comparison.results import check_planned_sequences, load_results
from ..dataset.sources import open_source
from ..errors import InputError
from ..geometry.trajectory_formats import TrajectoryFormat
from ..runs.run_report import sequence_block
from ..runs.run_specs import say_estimate_format, select_runs
from ..seeds import SEED_MAX
from .benchmark_outputs import OUTPUT_FILES, RECORDINGS_FOLDER, planned_outputs, write_outputs
from .cache import ResultCache
from .executors import make_executor
from .plan import plan_tasks
from .runner import TaskResult
from .suite import run_benchmark


@dataclass(frozen=True)
class BenchmarkResult:
    """The results of the tasks that finished (in task order), how many were planned, whether a stop
    request cut the benchmark short, and the files written."""

    results: tuple[TaskResult, ...]
    planned: int
    interrupted: bool
    written: tuple[Path, ...]

    @property
    def failed(self) -> int:
        """How many of the finished tasks failed (the others are reported all the same)."""
        return sum(not result.ok for result in self.results)


def benchmark(
    sequences: Sequence[str] = (),
    *,
    pipeline: str | Sequence[str] | None = None,
    max_frames: int | None = None,
    scenario_frames: int | None = None,
    resolution: tuple[int, int] = (640, 480),
    jobs: int | None = None,
    executor: str = "local",
    ray_address: str | None = None,
    out: Path = Path("benchmark-results"),
    record: bool = False,
    params: Sequence[str] = (),
    config: Path | None = None,
    seed: int = 0,
    trials: int = 1,
    timeout: float | None = None,
    cache: bool = True,
    estimates: Sequence[str] = (),
    format: TrajectoryFormat | None = None,
    compare: Path | None = None,
    quiet: bool = True,
) -> BenchmarkResult:
    """Run every sequence × run pair, evaluate it, and write ``results.csv``, ``results.json``,
    ``report.md`` and the charts into ``out``.

    ``sequences`` are TUM folders, TUM sequence names or synthetic scenarios (none: the seven
    synthetic scenarios, rendered at ``scenario_frames`` frames and ``resolution``); ``pipeline``
    names the runs (default: both built-in pipelines, or none beside ``estimates``, each
    ``NAME=FILE`` of the one sequence, read in ``format`` or a detected one). ``params`` (after
    ``config``) set parameters, ``max_frames`` cuts every sequence. Each pair runs ``trials``
    times with seeds ``seed`` to ``seed + trials - 1``. Tasks run ``jobs`` at once on ``executor``
    (local or ray, at ``ray_address``), each stopped after ``timeout`` seconds; ``cache`` reuses
    unchanged tasks' results; ``record`` also writes a recording per task into
    ``out/recordings``; ``compare`` is an earlier benchmark's ``out`` that report.md compares
    with. ``quiet`` hides the progress on stderr.

    Options and outputs are checked before any scenario is rendered; bad input is an
    :class:`~viewer_slam.errors.InputError`. A failed task is a failed row, never an exception.
    """
    runner = make_executor(executor, jobs, ray_address)  # checks the options before any scenario is generated
    if seed + trials - 1 > SEED_MAX:
        raise InputError(
            f"--trials {trials} with --seed {seed}: the last trial's seed {seed + trials - 1} is beyond {SEED_MAX}"
        )
    choice = pipeline if pipeline is None or isinstance(pipeline, str) else ",".join(pipeline) or None
    names, named = select_runs(choice, estimates)
    other = load_results(compare) if compare is not None else None
    if out.exists() and not out.is_dir():
        raise InputError.at(out, "is a file; --out takes a folder")
    for name in OUTPUT_FILES:
        check_writable(out / name)
    with exclusive([out]):
        tasks = plan_tasks(
            list(sequences) or None,
            names,
            max_frames=max_frames,
            scenario_frames=scenario_frames,
            resolution=resolution,
            assignments=params,
            config=config,
            seed=seed,
            timeout_s=timeout,
            recordings=out / RECORDINGS_FOLDER if record else None,
            estimates=named,
            estimate_format=format,
            trials=trials,
            progress=not quiet,
        )
        refuse_inputs_as_outputs(
            planned_outputs(out, tasks),
            {
                **{
                    task.estimate: f"--estimate {task.pipeline}={task.estimate}"
                    for task in tasks
                    if task.estimate is not None
                },
                **({config: f"--config {config}"} if config is not None else {}),
            },
        )
        if not quiet:
            for task in tasks:
                if task.estimate is not None:
                    say_estimate_format(task.pipeline, task.estimate, task.estimate_format, given=bool(format))
        if other is not None:
            folders = {task.name: task.sequence for task in tasks}
            check_planned_sequences(
                other, {name: sequence_block(open_source(folder)) for name, folder in folders.items()}
            )
        outcome = run_benchmark(tasks, runner, ResultCache() if cache else None, progress=not quiet)
        paths = write_outputs(outcome.results, out, compare_with=other, recorded=record)
    return BenchmarkResult(tuple(outcome.results), len(tasks), outcome.interrupted, tuple(paths))
