"""A benchmark run: cached results first, the rest on an executor, with one progress bar on stderr.

Ctrl-C (or SIGTERM) stops the run: the tasks that finished are returned, in order, so that
their rows are written. A task that records sends its files back with its result; they are
written beside the task's recording path here, on the driver, as each result arrives.
"""

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from ..atomic import StagedFiles
from ..errors import Interrupted
from .cache import ResultCache
from .executors import Executor, run_tasks
from .runner import BenchmarkTask, TaskResult


@dataclass
class BenchmarkOutcome:
    """The results of the tasks that finished, in task order; ``interrupted`` if some never ran."""

    results: list[TaskResult]
    interrupted: bool = False


def run_benchmark(
    tasks: Sequence[BenchmarkTask], executor: Executor, cache: ResultCache | None = None, *, progress: bool = True
) -> BenchmarkOutcome:
    """Results for ``tasks``; cached ones are not re-run, new successes are cached."""
    cached = {index: cache.load(task) for index, task in enumerate(tasks)} if cache is not None else {}
    results: dict[int, TaskResult] = {index: result for index, result in cached.items() if result is not None}
    pending = [index for index in range(len(tasks)) if index not in results]
    position = {id(tasks[index]): index for index in pending}
    running: list[str] = []
    interrupted = False
    columns = (
        TextColumn("[bold]benchmark"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TextColumn("{task.fields[running]}"),
    )
    with Progress(*columns, console=Console(stderr=True), disable=not progress) as bar:
        overall = bar.add_task("benchmark", total=len(tasks), completed=len(results), running="")

        def started(task: BenchmarkTask) -> None:
            running.append(task.label)
            bar.update(overall, running=", ".join(running))

        def finished(task: BenchmarkTask, result: TaskResult) -> None:
            running.remove(task.label)
            result = deliver_files(task, result)
            bar.update(overall, advance=1, running=", ".join(running))
            results[position[id(task)]] = result
            if not result.ok:
                bar.console.print(f"[red]failed[/red] {task.label}: {result.error}")
            if cache is not None:
                cache.store(task, result)

        try:
            if pending:
                run_tasks([tasks[index] for index in pending], executor, on_start=started, on_finish=finished)
        except (KeyboardInterrupt, Interrupted):
            interrupted = True
    return BenchmarkOutcome([results[index] for index in sorted(results)], interrupted)


def deliver_files(task: BenchmarkTask, result: TaskResult) -> TaskResult:
    """Write the files ``result`` brought from its worker beside ``task.recording``, all renamed into
    place together; the result without them, or a failed result when they cannot be written."""
    if not result.files:
        return result
    assert task.recording is not None  # only a task that records brings files
    folder = Path(task.recording).parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with StagedFiles() as staged:
            for name, data in result.files.items():
                staged.path(folder / name).write_bytes(data)
            staged.commit()
    except OSError as error:
        return TaskResult.failure(task, f"cannot write the recording into {folder}: {error.strerror or error}")
    result.files = {}
    return result
