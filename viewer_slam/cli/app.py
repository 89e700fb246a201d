"""The typer application that every command module registers on."""

from typing import Any

import typer
import typer.core

app = typer.Typer(
    name="viewslam",
    help="A 3D visual debugger and benchmark for RGB-D SLAM, recorded into Rerun.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _value_type_of(option: typer.core.TyperOption, ctx: Any) -> str | None:
    """The value type the help shows beside an option: none for a flag or a counter, which take no
    value. typer 0.29's rich help asks every option for it and prints ``--help <bool>``; its plain
    help (click's layout) already leaves flags and counters bare, and so does this."""
    if option.is_flag or option.count:
        return None
    return _typer_value_type(option, ctx)


_typer_value_type = typer.core.TyperOption.display_type_rich
typer.core.TyperOption.display_type_rich = _value_type_of  # type: ignore[method-assign,assignment]
