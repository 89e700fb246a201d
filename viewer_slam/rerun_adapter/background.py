"""The recorder's work on a thread of its own, so that a recording does not slow the run.

Encoding images, thinning snapshots and building Rerun archetypes cost time of their own;
done in the frame loop, every frame waits for them. Here each call is
queued and run on one thread, in the order it was made: Rerun keeps one thread's log calls
in order and holds each thread's timeline (``set_time``) for that thread alone, so the
recording holds the same entities, values and times as if the calls had run in the loop.
The pipelines' events are not changed once emitted (they carry copies), so running the
calls later sees what running them at once would have seen.

The queue is bounded, so a recorder slower than the pipeline holds the frame loop back
rather than frames piling up in memory. A call that raises stops the thread's work; the
error is raised in the caller's thread at its next call or at :meth:`RecordingThread.drain`.
"""

import queue
import threading
from collections.abc import Callable
from typing import Any

# Calls that may wait: some twenty per frame and pipeline, so a dozen frames (whose images
# the queue keeps alive meanwhile).
MAX_PENDING_CALLS = 256
_STOP = None


class RecordingThread:
    """Runs the calls :meth:`submit` is given on one thread, in order; a context manager."""

    def __init__(self, max_pending: int = MAX_PENDING_CALLS):
        self._calls: queue.Queue = queue.Queue(max_pending)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="viewslam-recorder", daemon=True)
        self._thread.start()

    def submit(self, function: Callable[..., Any], *args: Any) -> None:
        """Queue ``function(*args)``; raises the error of an earlier call, if one failed."""
        self._raise_error()
        self._calls.put((function, args))

    def sink(self, function: Callable[[Any], None]) -> Callable[[Any], None]:
        """A sink that queues each item for ``function``."""
        return lambda item: self.submit(function, item)

    def drain(self) -> None:
        """Wait until every queued call has run; raises the error of one that failed."""
        self._calls.join()
        self._raise_error()

    def close(self) -> None:
        """Run what is queued, then end the thread."""
        self._calls.put(_STOP)
        self._thread.join()

    def __enter__(self) -> "RecordingThread":
        return self

    def __exit__(self, *_) -> None:
        self.close()

    def _raise_error(self) -> None:
        if self._error is not None:
            raise self._error

    def _run(self) -> None:
        while True:
            call = self._calls.get()
            try:
                if call is _STOP:
                    return
                if self._error is None:  # after a failure the rest is skipped, never half-done
                    function, args = call
                    function(*args)
            except BaseException as error:  # noqa: BLE001 (handed to the caller's thread)
                self._error = error
            finally:
                self._calls.task_done()
