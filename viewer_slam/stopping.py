"""The one rule for stop signals (Ctrl-C, SIGTERM, SIGHUP), whichever command or loop receives them.

The first stop signal asks the command to stop; a second one, of any kind, while the first is
being honoured, is absorbed (a terminal closing right after a scheduler's SIGTERM must not cut
the clean-up short); a third aborts at once. Signals are counted once per process, so the
count carries from a loop that stops at its own safe points back to the command around it.

How the first is honoured depends on where it lands: by default it raises
:class:`~viewer_slam.errors.Interrupted` at once, wherever the main thread is; inside
:func:`at_safe_points` it only sets a request that the loop checks between two steps (a frame
rendered, a chunk downloaded), so that no library (a process pool starting its workers, a
file being written) is interrupted halfway through its own bookkeeping.
"""

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from .errors import Interrupted

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
ABORT_AT = 3
"""The stop signal that aborts at once, however the earlier ones are being honoured."""

Announce = Callable[[str, int], None]
"""Called with a stop signal's name and its number in the count (1 or 2), before it takes effect."""


class _Count:
    """The signals received since :func:`installed`, and how the next one is honoured."""

    def __init__(self) -> None:
        self.received = 0
        self.requested: str | None = None  # the first signal's name
        self.deferred = False
        self.announce: Announce | None = None

    def handle(self, signum: int, frame: object) -> None:
        name = signal.Signals(signum).name
        self.received += 1
        if self.received >= ABORT_AT:
            raise Interrupted(name)
        if self.announce is not None:
            self.announce(name, self.received)
        if self.received > 1:
            return  # absorbed: the first is being honoured
        self.requested = name
        if not self.deferred:
            raise Interrupted(name)


_count = _Count()


@contextmanager
def installed() -> Iterator[None]:
    """The rule in force for the block, the count started afresh (the command line's whole run);
    the handlers before it are restored after. Outside the main thread, nothing is installed."""
    global _count
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    outer, _count = _count, _Count()
    previous = {number: signal.signal(number, _count.handle) for number in STOP_SIGNALS}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        _count = outer


def ignore() -> None:
    """From now on, stop signals do nothing: the process is leaving with its exit code (its
    interpreter's own exit, which joins threads and child processes, is not cut short)."""
    if threading.current_thread() is threading.main_thread():
        for number in STOP_SIGNALS:
            signal.signal(number, signal.SIG_IGN)


class SafePoints:
    """What a loop inside :func:`at_safe_points` asks between two steps."""

    @property
    def requested(self) -> bool:
        """Whether a stop signal has asked the loop to stop."""
        return _count.requested is not None

    def __call__(self) -> bool:
        return self.requested

    def check(self) -> None:
        """Raise :class:`Interrupted` if a stop signal asked to stop: the loop is at a safe point."""
        if _count.requested is not None:
            raise Interrupted(_count.requested)


@contextmanager
def at_safe_points(announce: Announce | None = None) -> Iterator[SafePoints]:
    """For the block, the first stop signal only sets a request the loop checks at its safe points
    (``announce`` says so, and hears of the second); the third still aborts at once. A request
    that came before the block is in force at once. Outside :func:`installed` (a library used
    from a program of its own), the block installs the rule for itself."""
    if threading.current_thread() is not threading.main_thread():
        yield SafePoints()
        return
    own = signal.getsignal(signal.SIGTERM) != _count.handle
    with installed() if own else _nothing():
        before = (_count.deferred, _count.announce)
        _count.deferred, _count.announce = True, announce
        try:
            yield SafePoints()
        finally:
            _count.deferred, _count.announce = before


@contextmanager
def _nothing() -> Iterator[None]:
    yield


def raised_by_a_stop(error: BaseException) -> bool:
    """Whether ``error`` wraps a Ctrl-C or stop signal: a compiled extension that is interrupted while
    it loads re-raises the signal's exception as ``ImportError: initialization failed`` (pybind11)."""
    seen: set[int] = set()
    link: BaseException | None = error
    while link is not None and id(link) not in seen:
        if isinstance(link, (Interrupted, KeyboardInterrupt)):
            return True
        seen.add(id(link))
        link = link.__cause__ or link.__context__
    return False
