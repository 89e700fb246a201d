"""Stdout for tables: a console whose closed pipe is the command's one line, tables that are never
cut, as wide as their content, whatever the terminal or pipe, and text that any locale can show."""

import codecs
import errno
import os
import sys
import unicodedata
from typing import TextIO

from rich.console import Console
from rich.measure import Measurement
from rich.table import Table

UNLIMITED = 10_000
STDOUT_FD = 1
ASCII_ERRORS = "viewslam-ascii"
"""The error handler that writes what a stream cannot encode as its nearest ASCII."""
_ASCII = {
    "—": "-",
    "–": "-",
    "−": "-",
    "…": "...",
    "·": "-",
    "°": " deg",
    "±": "+/-",
    "×": "x",
    "→": "->",
    "≤": "<=",
    "≥": ">=",
    "━": "-",
    "─": "-",
    "│": "|",
    "█": "#",
    "•": "*",
    "’": "'",
    "“": '"',
    "”": '"',
}
"""What our tables, progress lines and messages print beyond ASCII, as the ASCII that says the same."""


def _nearest_ascii(error: UnicodeError) -> tuple[str, int]:
    if not isinstance(error, UnicodeEncodeError):
        raise error
    text = error.object[error.start : error.end]
    return "".join(
        _ASCII.get(character) or unicodedata.normalize("NFKD", character).encode("ascii", "ignore").decode() or "?"
        for character in text
    ), error.end


codecs.register_error(ASCII_ERRORS, _nearest_ascii)


def degrade_to_ascii(stream: TextIO | None) -> None:
    """Let ``stream`` write what its encoding cannot (an ASCII or Latin-1 locale, ``LANG=C``,
    ``PYTHONIOENCODING=ascii``) as the nearest ASCII instead of failing; rich, seeing the
    encoding, draws its tables and bars in ASCII already."""
    encoding = getattr(stream, "encoding", None)
    if stream is None or not encoding or not hasattr(stream, "reconfigure"):
        return
    try:
        "".join(_ASCII).encode(encoding)
    except UnicodeEncodeError:
        stream.reconfigure(errors=ASCII_ERRORS)
    except LookupError:
        return


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


class ClosedStdout:
    """Stands in for a stdout the command was started without (``>&-``): a write fails as it would on
    the closed descriptor, so output that cannot go anywhere is an error, not silently dropped."""

    def write(self, text: str) -> int:
        raise OSError(errno.EBADF, os.strerror(errno.EBADF))

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        return STDOUT_FD

    def isatty(self) -> bool:
        return False


def guard_closed_stdout() -> None:
    """With descriptor 1 closed, hold it with /dev/null, so that no file the command opens gets it
    (and receives what a library prints), and make Python's own writes to stdout fail."""
    if sys.stdout is not None:
        return
    os.dup2(os.open(os.devnull, os.O_WRONLY), STDOUT_FD)
    sys.stdout = ClosedStdout()


def drop_stdout() -> None:
    """Point stdout at /dev/null, so that what is still buffered does not fail again at exit."""
    if sys.stdout is not None:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
