"""Pipeline parameters: dataclasses whose fields carry the original systems' names.

A field declared with :func:`param` is addressed by its ``key`` (``Odom/ResetCountdown``
for RTAB-Map, ``predecessor_candidates`` for RGB-D SLAM) on the command line
(``--param KEY=VALUE``) and in TOML configs, and is reported under that key.
"""

import dataclasses
import tomllib
import typing
from pathlib import Path
from typing import Any

from ..errors import InputError


def param(default: Any, key: str | None = None, help: str = "", choices: tuple | None = None, *,
          ge: float | None = None, gt: float | None = None, le: float | None = None, lt: float | None = None):
    """A dataclass field with the parameter's external name, a help text and its allowed values.

    ``choices`` lists the allowed values; ``ge``/``gt``/``le``/``lt`` bound a number (every
    number must also be finite). The bounds are the declaration that validation, ``--help``
    and the docs read.
    """
    bounds = {name: value for name, value in (("ge", ge), ("gt", gt), ("le", le), ("lt", lt)) if value is not None}
    return dataclasses.field(default=default, metadata={"key": key, "help": help, "choices": choices,
                                                        "bounds": bounds})


def _key(field: dataclasses.Field) -> str:
    return field.metadata.get("key") or field.name


def param_fields(params_type: type) -> dict[str, dataclasses.Field]:
    """External key -> dataclass field, in declaration order."""
    return {_key(f): f for f in dataclasses.fields(params_type)}


def params_to_dict(params: Any) -> dict[str, Any]:
    """The parameters under their external keys, as recorded in reports."""
    return {_key(f): getattr(params, f.name) for f in dataclasses.fields(params)}


def _convert(key: str, value: Any, field: dataclasses.Field, kind: type, source: str) -> Any:
    def bad(expected: str) -> InputError:
        return InputError(f"{source}: parameter {key} expects {expected}, got {value!r}")

    if kind is bool:
        if isinstance(value, bool):
            converted = value
        elif str(value).lower() in ("true", "1", "yes", "on"):
            converted = True
        elif str(value).lower() in ("false", "0", "no", "off"):
            converted = False
        else:
            raise bad("true or false")
    elif kind is int:
        try:
            if isinstance(value, bool) or float(value) != int(float(value)):
                raise ValueError
            converted = int(float(value))
        except (TypeError, ValueError):
            raise bad("an integer") from None
    elif kind is float:
        try:
            if isinstance(value, bool):
                raise ValueError
            converted = float(value)
        except (TypeError, ValueError):
            raise bad("a number") from None
    else:
        converted = str(value)
    choices = field.metadata.get("choices")
    if choices and converted not in choices:
        raise InputError(f"{source}: parameter {key} must be one of {', '.join(map(str, choices))}, got {value!r}")
    return converted


def apply_overrides(params: Any, overrides: dict[str, Any], source: str) -> Any:
    """A copy of ``params`` with ``overrides`` (external key -> raw value) applied.

    Unknown keys and values of the wrong type raise :class:`InputError` naming ``source``
    and, for unknown keys, the valid keys.
    """
    fields = param_fields(type(params))
    hints = typing.get_type_hints(type(params))
    changes = {}
    for key, value in overrides.items():
        if key not in fields:
            raise InputError(f"{source}: unknown parameter {key!r}; valid: {', '.join(fields)}")
        field = fields[key]
        changes[field.name] = _convert(key, value, field, hints[field.name], source)
    return dataclasses.replace(params, **changes)


def parse_assignments(assignments: list[str]) -> dict[str, str]:
    """``["KEY=VALUE", ...]`` -> dict, rejecting items without ``=``."""
    parsed = {}
    for item in assignments:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--param {item!r}: expected KEY=VALUE")
        parsed[key.strip()] = value.strip()
    return parsed


def load_config(path: Path) -> dict[str, Any]:
    """Read a TOML parameter file: flat ``KEY = value`` lines and/or one table per pipeline."""
    try:
        with open(path, "rb") as handle:
            return tomllib.load(handle)
    except FileNotFoundError:
        raise InputError.at(path, "no such file") from None
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise InputError.at(path, f"cannot read config: {error}") from None


def resolve_params(params_types: dict[str, type], assignments: list[str] = (), config: Path | None = None) -> dict[str, Any]:
    """Parameters per pipeline from defaults, then ``config``, then ``--param`` assignments.

    A config table named after a pipeline applies to it alone; flat keys and ``--param``
    keys apply to every selected pipeline that has them, and a key that none of them has
    is an error listing the valid keys.
    """
    resolved = {name: kind() for name, kind in params_types.items()}
    layers: list[tuple[str, dict[str, Any]]] = []
    if config is not None:
        data = load_config(config)
        for name in params_types:
            table = data.get(name)
            if isinstance(table, dict):
                resolved[name] = apply_overrides(resolved[name], table, str(config))
        flat = {k: v for k, v in data.items() if not isinstance(v, dict)}
        layers.append((str(config), flat))
    layers.append(("--param", parse_assignments(list(assignments))))
    for source, values in layers:
        for key, value in values.items():
            owners = [name for name, kind in params_types.items() if key in param_fields(kind)]
            if not owners:
                valid = sorted({k for kind in params_types.values() for k in param_fields(kind)})
                raise InputError(f"{source}: unknown parameter {key!r} for {', '.join(params_types)}; valid: {', '.join(valid)}")
            for name in owners:
                resolved[name] = apply_overrides(resolved[name], {key: value}, source)
    return resolved
