"""Ctrl-C (and SIGTERM, SIGHUP) as a request to stop after the current frame, not an
exception at a random line."""

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from ..errors import Interrupted

# A terminal closing (SIGHUP) or a job scheduler stopping the run (SIGTERM) is a Ctrl-C.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class StopRequest:
    """Set by the first stop signal; a second one only repeats the request (the run still stops
    after its frame and writes what was recorded); a third aborts at once (:class:`Interrupted`)."""

    ABORT_AT = 3

    def __init__(self):
        self.requested = False
        self.received = 0

    def __call__(self) -> bool:
        return self.requested

    def _handle(self, signum, frame) -> None:
        self.received += 1
        name = signal.Signals(signum).name
        if self.received >= self.ABORT_AT:
            raise Interrupted(name)
        self.requested = True
        if self.received == 1:
            print(f"\nviewslam: {name}: stopping after this frame and writing what was recorded (a third "
                  f"stop signal aborts)", file=sys.stderr)
        else:
            print(f"viewslam: {name}: already stopping after this frame (one more stop signal aborts)",
                  file=sys.stderr)

    @contextmanager
    def installed(self) -> Iterator["StopRequest"]:
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        previous = {number: signal.signal(number, self._handle) for number in STOP_SIGNALS}
        try:
            yield self
        finally:
            for number, handler in previous.items():
                signal.signal(number, handler)
