"""Stdout for tables: a console whose closed pipe is the command's one line, and tables that are
never cut, as wide as their content, whatever the terminal or pipe."""

import errno
import os

from rich.console import Console
from rich.measure import Measurement
from rich.table import Table

UNLIMITED = 10_000


class StdoutConsole(Console):
    """A rich console on stdout that lets a closed pipe's error reach the command line, which says
    so in one line (rich itself exits with code 1 and says nothing)."""

    def on_broken_pipe(self) -> None:
        self.quiet = True
        raise BrokenPipeError(errno.EPIPE, os.strerror(errno.EPIPE))


def print_table(table: Table, console: Console | None = None) -> None:
    """Print ``table`` at its natural width (rich would otherwise shrink it to the terminal, or to
    80 columns when piped, and cut numbers with an ellipsis)."""
    console = console or StdoutConsole()
    width = Measurement.get(console, console.options.update_width(UNLIMITED), table).maximum
    terminal_width = console.width
    console.width = max(width, terminal_width)  # rich never renders wider than the console
    try:
        console.print(table, crop=False)
    finally:
        console.width = terminal_width
