"""typer's exceptions recognised without importing typer: a command that failed before the
command line loaded it is not made to load it just to report the failure."""

import sys
from typing import Protocol


def typer_exception(name: str) -> type[BaseException]:
    """typer's exception class ``name`` once typer is loaded (an ``except`` clause evaluates it only
    when an exception is being matched), else a class nothing raises."""
    typer = sys.modules.get("typer")
    return getattr(typer, name) if typer is not None else _Never


class _Never(Exception):
    pass


class UsageError(Protocol):
    """What the command line reads of typer's usage errors (click's ``ClickException``)."""

    def format_message(self) -> str: ...
