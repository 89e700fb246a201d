"""Where tasks run: a local process pool or Ray (a local instance or an existing cluster).

Both executors run :func:`~viewer_slam.benchmark.runner.execute_task` in worker processes
and turn infrastructure failures (a worker that died, a Ray error) into failed results, so
every task ends with a result and the rest of the benchmark finishes. :func:`run_tasks`
keeps exactly as many tasks in flight as the executor has slots, which is what lets the
progress display name the tasks that are running rather than queued.
"""

import multiprocessing
import os
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

from .. import code_paths
from ..errors import InputError
from .runner import BenchmarkTask, TaskResult, execute_task


class Executor(Protocol):
    slots: int

    def __enter__(self) -> "Executor": ...

    def __exit__(self, *exc) -> None: ...

    def submit(self, task: BenchmarkTask) -> Any: ...

    def wait(self, handles: list[Any]) -> list[Any]:
        """The handles among ``handles`` that have finished (at least one; blocks until then)."""

    def result(self, handle: Any, task: BenchmarkTask) -> TaskResult: ...


def run_tasks(
    tasks: Sequence[BenchmarkTask],
    executor: Executor,
    *,
    on_start: Callable[[BenchmarkTask], None] = lambda task: None,
    on_finish: Callable[[BenchmarkTask, TaskResult], None] = lambda task, result: None,
) -> list[TaskResult]:
    """Run every task on ``executor``; results in the order of ``tasks``."""
    results: dict[int, TaskResult] = {}
    queue = deque(range(len(tasks)))
    in_flight: dict[Any, int] = {}
    with executor:
        while queue or in_flight:
            while queue and len(in_flight) < executor.slots:
                index = queue.popleft()
                on_start(tasks[index])
                in_flight[executor.submit(tasks[index])] = index
            for handle in executor.wait(list(in_flight)):
                index = in_flight.pop(handle)
                results[index] = executor.result(handle, tasks[index])
                on_finish(tasks[index], results[index])
    return [results[index] for index in range(len(tasks))]


def _worker_pool(workers: int) -> ProcessPoolExecutor:
    """Workers forked from a fresh server process that has the task code imported.

    Not forked from this process: its threads (the progress display, a Ray driver) could
    hold a lock at the moment of the fork and leave it locked forever in the child.
    """
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([execute_task.__module__])
    return ProcessPoolExecutor(workers, mp_context=context)


class LocalExecutor:
    """A pool of ``jobs`` worker processes (default: one per core).

    A worker that dies outright (a segfault in native code, the OOM killer) breaks the whole
    pool; the tasks that were in flight are then re-run one at a time in a fresh process, so
    the one that kills its worker is reported failed and the others still complete.
    """

    def __init__(self, jobs: int | None = None):
        self.slots = jobs or os.cpu_count() or 1
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> "LocalExecutor":
        self._pool = _worker_pool(self.slots)
        return self

    def __exit__(self, *exc) -> None:
        self._started().shutdown(wait=exc[0] is None, cancel_futures=True)  # an interrupt does not wait for tasks

    def submit(self, task: BenchmarkTask) -> Future:
        try:
            return self._started().submit(execute_task, task)
        except BrokenProcessPool:
            self._started().shutdown(wait=False)
            self._pool = _worker_pool(self.slots)
            return self._pool.submit(execute_task, task)

    def _started(self) -> ProcessPoolExecutor:
        """The pool ``__enter__`` started: tasks are submitted inside the ``with`` block only."""
        if self._pool is None:
            raise RuntimeError("LocalExecutor used outside its with block")
        return self._pool

    def wait(self, handles: list[Future]) -> list[Future]:
        return list(wait(handles, return_when=FIRST_COMPLETED).done)

    def result(self, handle: Future, task: BenchmarkTask) -> TaskResult:
        try:
            return handle.result()
        except BrokenProcessPool:
            return _run_alone(task)


def _run_alone(task: BenchmarkTask) -> TaskResult:
    with _worker_pool(1) as solo:
        try:
            return solo.submit(execute_task, task).result()
        except BrokenProcessPool:
            return TaskResult.failure(task, "worker process died")


class RayExecutor:
    """Ray tasks, one CPU each, on an existing cluster (``address``) or a local instance.

    A local instance gets ``jobs`` CPUs (default: one per core) and is shut down afterwards;
    on a cluster, ``jobs`` defaults to the cluster's CPU count.
    """

    def __init__(self, jobs: int | None = None, address: str | None = None):
        self.jobs, self.address = jobs, address
        self.slots = 0
        self._started = False

    def __enter__(self) -> "RayExecutor":
        try:
            import ray
        except ImportError:
            raise InputError("--executor ray: Ray is not installed; pip install 'viewer-slam[ray]'") from None
        self._ray = ray
        if not ray.is_initialized():
            options = {"address": self.address} if self.address else {"num_cpus": self.jobs or os.cpu_count()}
            try:
                # Workers on other nodes do not inherit this process's environment: hand them NumPy's hold.
                ray.init(
                    **options,
                    include_dashboard=False,
                    log_to_driver=False,
                    configure_logging=False,
                    runtime_env={"env_vars": code_paths.environment()},
                )
            except ConnectionError as error:
                raise InputError(f"--ray-address {self.address}: cannot connect: {error}") from None
            self._started = True
        self.slots = self.jobs or max(int(ray.cluster_resources().get("CPU", 1)), 1)
        self._remote = ray.remote(num_cpus=1, max_retries=0)(execute_task)
        return self

    def __exit__(self, *exc) -> None:
        if self._started:
            self._ray.shutdown()

    def submit(self, task: BenchmarkTask):
        return self._remote.remote(task)

    def wait(self, handles: list) -> list:
        ready, _ = self._ray.wait(handles, num_returns=1)
        return ready

    def result(self, handle, task: BenchmarkTask) -> TaskResult:
        try:
            return self._ray.get(handle)
        except self._ray.exceptions.RayError as error:
            summary = str(error).strip().splitlines()
            return TaskResult.failure(task, f"{type(error).__name__}: {summary[0] if summary else 'no message'}")


def make_executor(kind: str, jobs: int | None = None, ray_address: str | None = None) -> Executor:
    if kind == "local":
        if ray_address:
            raise InputError("--ray-address needs --executor ray")
        return LocalExecutor(jobs)
    if kind == "ray":
        return RayExecutor(jobs, ray_address)
    raise InputError(f"--executor {kind!r}: expected local or ray")
