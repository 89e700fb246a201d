"""Ctrl-C (and SIGTERM, SIGHUP) during `viewslam record`: a request to stop after the current frame
and write what was recorded, not an exception at a random line (the rule: ``stopping.py``)."""

import sys
from collections.abc import Iterator
from contextlib import contextmanager

from ..stopping import SafePoints, at_safe_points


class StopRequest:
    """The first stop signal stops the run after its frame, which then writes what was recorded;
    a second one only repeats the request; a third aborts at once (:class:`Interrupted`)."""

    @staticmethod
    def _announce(name: str, count: int) -> None:
        if count == 1:
            print(
                f"\nviewslam: {name}: stopping after this frame and writing what was recorded (a third "
                f"stop signal aborts)",
                file=sys.stderr,
            )
        else:
            print(f"viewslam: {name}: already stopping after this frame (one more stop signal aborts)", file=sys.stderr)

    @contextmanager
    def installed(self) -> Iterator[SafePoints]:
        with at_safe_points(self._announce) as stop:
            yield stop
