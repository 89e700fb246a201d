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
    """Set by the first stop signal; a second one aborts at once (:class:`Interrupted`)."""

    def __init__(self):
        self.requested = False

    def __call__(self) -> bool:
        return self.requested

    def _handle(self, signum, frame) -> None:
        if self.requested:
            raise Interrupted(signal.Signals(signum).name)
        self.requested = True
        print(f"\nviewslam: {signal.Signals(signum).name}: stopping after this frame and writing what was "
              "recorded (Ctrl-C again to abort)", file=sys.stderr)

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
