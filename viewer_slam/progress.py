"""A progress line on stderr for a counted step (frames rendered): done, rate and time left.

Steps that take more than a second must not leave the terminal blank. Like the other
displays (``viewslam record``, ``benchmark``, ``download``) it is a rich progress bar on
stderr, so stdout stays for results; rich redraws it only on a terminal and prints the
final line once when stderr is a file or a pipe.
"""

import contextlib
from collections.abc import Callable, Iterator

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, ProgressColumn, Task, TextColumn, TimeRemainingColumn
from rich.text import Text


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
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), RateColumn(unit),
               TimeRemainingColumn())
    with Progress(*columns, console=Console(stderr=True), disable=not enabled) as bar:
        task = bar.add_task(description, total=total)
        yield lambda: bar.advance(task)
