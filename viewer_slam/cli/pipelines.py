"""`viewslam pipelines`: the built-in and plugin pipelines, with their parameters."""

import sys
from typing import TYPE_CHECKING

import typer

from ..errors import InputError
from .app import app

if TYPE_CHECKING:
    from pydantic import BaseModel

_BOUND_SIGNS = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<"}


@app.command("pipelines")
def pipelines_command() -> None:
    """List the pipelines `record --pipeline` and `benchmark --pipeline` accept, with their parameters.

    A plugin that cannot be loaded is reported on one line and left out; the others are listed.
    """
    from ..pipelines.base import PIPELINE_MODULES, load_plugin, pipeline_class, plugin_entry_points

    listed = [(name, "built-in", pipeline_class(name)) for name in PIPELINE_MODULES]
    for name, plugin in plugin_entry_points().items():
        try:
            listed.append((name, f"plugin from {_distribution(plugin)}", load_plugin(plugin)))
        except InputError as error:
            print(f"viewslam: warning: {error}", file=sys.stderr)
    for name, origin, pipeline in listed:
        summary = _summary(pipeline)
        typer.echo(f"{name} ({origin}){': ' + summary if summary else ''}")
        for line in _parameter_lines(pipeline.Params):
            typer.echo(f"  {line}")


def _summary(pipeline) -> str:
    """The first paragraph of the class docstring on one line (a wrapped sentence stays whole)."""
    paragraph = (pipeline.__doc__ or "").strip().split("\n\n")[0]
    return " ".join(paragraph.split())


def _distribution(plugin) -> str:
    dist = plugin.dist
    return f"{dist.name} {dist.version}" if dist is not None else plugin.value


def _parameter_lines(params_type: type["BaseModel"]) -> list[str]:
    """``KEY = DEFAULT (TYPE, BOUNDS)  DESCRIPTION`` per parameter, keys aligned."""
    from ..pipelines.params import bounds_of, choices_of, keyed_fields, kind_of

    rows = []
    for key, field in keyed_fields(params_type).items():
        limits = [f"{_BOUND_SIGNS[name]} {value:g}" for name, value in bounds_of(field).items()]
        if choices_of(field):
            limits.append("one of " + ", ".join(map(repr, choices_of(field))))
        default = field.get_default(call_default_factory=True)
        rows.append((f"{key} = {default!r}", ", ".join([kind_of(field).__name__, *limits]), field.description or ""))
    width = max((len(row[0]) for row in rows), default=0)
    return [f"{setting:<{width}}  ({details})  {help_text}".rstrip() for setting, details, help_text in rows]
