"""Tables on stdout that are never cut: as wide as their content, whatever the terminal or pipe."""

from rich.console import Console
from rich.measure import Measurement
from rich.table import Table

UNLIMITED = 10_000


def print_table(table: Table, console: Console | None = None) -> None:
    """Print ``table`` at its natural width (rich would otherwise shrink it to the terminal, or to
    80 columns when piped, and cut numbers with an ellipsis)."""
    console = console or Console()
    width = Measurement.get(console, console.options.update_width(UNLIMITED), table).maximum
    terminal_width = console.width
    console.width = max(width, terminal_width)  # rich never renders wider than the console
    try:
        console.print(table, crop=False)
    finally:
        console.width = terminal_width
