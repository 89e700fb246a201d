"""Progress lines on stderr: the display every command's progress goes through, and a counted
step (frames rendered) with done, rate and time left.

Steps that take more than a second must not leave the terminal blank. Like the other
displays (``viewslam record``, ``benchmark``, ``download``) it is a rich progress bar on
stderr, so stdout stays for results; rich redraws it only on a terminal and prints the
final line once when stderr is a file or a pipe. A display left by an error or a stop signal
is cleared instead, so that the command's one line about it stands alone.
"""

import contextlib
from collections.abc import Callable, Iterator

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, ProgressColumn, Task, TextColumn, TimeRemainingColumn
from rich.text import Text


class StderrProgress(Progress):
    """A rich progress display on stderr that leaves no line behind when an exception ends it."""

    def __init__(self, *columns: str | ProgressColumn, enabled: bool = True, transient: bool = False):
        super().__init__(*columns, console=Console(stderr=True), disable=not enabled, transient=transient)

    def __exit__(self, exc_type, exc_value, traceback) -> None:
        if exc_type is not None:
            self.live.transient = True  # rich then neither prints the last state nor leaves it on screen
        super().__exit__(exc_type, exc_value, traceback)

    def stop(self) -> None:
        """As rich's, without the empty line it ends a file or pipe with when nothing stays shown."""
        if self.live.transient:
            self.live.stop()
        else:
            super().stop()


class RateColumn(ProgressColumn):
    """Items per second over rich's recent window ("…" until two items are done)."""

    def __init__(self, unit: str):
        super().__init__()
        self.unit = unit

    def render(self, task: Task) -> Text:
        return Text(f"{task.speed:5.1f} {self.unit}/s" if task.speed else f"    … {self.unit}/s")


@contextlib.contextmanager
def counted(description: str, total: int, unit: str, enabled: bool = True) -> Iterator[Callable[[], None]]:
    """A bar for ``total`` items; yields the function that counts one more done.

    Disabled (``--quiet``), nothing is printed and counting costs one call.
    """
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        RateColumn(unit),
        TimeRemainingColumn(),
    )
    with StderrProgress(*columns, enabled=enabled) as bar:
        task = bar.add_task(description, total=total)
        yield lambda: bar.advance(task)
