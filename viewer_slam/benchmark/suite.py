"""A benchmark run: cached results first, the rest on an executor, with one progress bar."""

from collections.abc import Sequence

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from .cache import ResultCache
from .executors import Executor, run_tasks
from .runner import BenchmarkTask, TaskResult


def run_benchmark(tasks: Sequence[BenchmarkTask], executor: Executor, cache: ResultCache | None = None,
                  *, progress: bool = True) -> list[TaskResult]:
    """Results for ``tasks`` in their order; cached ones are not re-run, new successes are cached."""
    cached = {index: cache.load(task) for index, task in enumerate(tasks)} if cache is not None else {}
    pending = [index for index in range(len(tasks)) if cached.get(index) is None]
    running: list[str] = []
    columns = (TextColumn("[bold]benchmark"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
               TextColumn("{task.fields[running]}"))
    with Progress(*columns, disable=not progress) as bar:
        overall = bar.add_task("benchmark", total=len(tasks), completed=len(tasks) - len(pending), running="")

        def started(task: BenchmarkTask) -> None:
            running.append(task.label)
            bar.update(overall, running=", ".join(running))

        def finished(task: BenchmarkTask, result: TaskResult) -> None:
            running.remove(task.label)
            bar.update(overall, advance=1, running=", ".join(running))
            if not result.ok:
                bar.console.print(f"[red]failed[/red] {task.label}: {result.error}")
            if cache is not None:
                cache.store(task, result)

        fresh = run_tasks([tasks[index] for index in pending], executor, on_start=started, on_finish=finished) \
            if pending else []
    results = dict(cached) | dict(zip(pending, fresh))
    return [results[index] for index in range(len(tasks))]
