"""`viewslam pipelines`: the built-in and plugin pipelines, with their parameters."""

import dataclasses
import sys
import typing

import typer

from ..errors import InputError
from .app import app

_BOUND_SIGNS = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<"}


@app.command("pipelines")
def pipelines_command() -> None:
    """List the pipelines `record --pipeline` and `benchmark --pipelines` accept, with their parameters.

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


def _parameter_lines(params_type: type) -> list[str]:
    """``KEY = DEFAULT (TYPE, BOUNDS)  HELP`` per parameter, keys aligned."""
    from ..pipelines.params import param_fields

    hints = typing.get_type_hints(params_type)
    rows = []
    for key, field in param_fields(params_type).items():
        default = field.default if field.default is not dataclasses.MISSING else field.default_factory()
        kind = getattr(hints[field.name], "__name__", str(hints[field.name]))
        limits = [f"{_BOUND_SIGNS[name]} {value:g}" for name, value in field.metadata.get("bounds", {}).items()]
        if field.metadata.get("choices"):
            limits.append("one of " + ", ".join(map(repr, field.metadata["choices"])))
        rows.append((f"{key} = {default!r}", ", ".join([kind, *limits]), field.metadata.get("help", "")))
    width = max((len(row[0]) for row in rows), default=0)
    return [f"{setting:<{width}}  ({details})  {help_text}".rstrip() for setting, details, help_text in rows]
