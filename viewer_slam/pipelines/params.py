"""Pipeline parameters: dataclasses whose fields carry the original systems' names.

A field declared with :func:`param` is addressed by its ``key`` (``Odom/ResetCountdown``
for RTAB-Map, ``predecessor_candidates`` for RGB-D SLAM) on the command line
(``--param KEY=VALUE``) and in TOML configs, and is reported under that key.
"""

import dataclasses
import difflib
import tomllib
import typing
from collections.abc import Sequence
from functools import cache
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


@dataclasses.dataclass(frozen=True)
class Ordered:
    """A rule between two parameters: ``lower`` stays below ``upper`` (at most equal to it when
    not ``strict``), unless ``upper`` is ``off`` (a value that means "no limit").

    A params dataclass lists its rules in a ``RELATIONS`` class attribute, by field name.
    """

    lower: str
    upper: str
    strict: bool = True
    off: float | None = None

    def problem(self, params: Any) -> str | None:
        low, high = getattr(params, self.lower), getattr(params, self.upper)
        if high == self.off or (low < high if self.strict else low <= high):
            return None
        keys = {f.name: _key(f) for f in dataclasses.fields(params)}
        relation = "above" if self.strict else "at least"
        unless = f", or {self.off:g} for no limit" if self.off is not None else ""
        return f"{keys[self.upper]} must be {relation} {keys[self.lower]} ({low}){unless}, got {high}"


def check_relations(params: Any, source: str) -> None:
    """Raise :class:`InputError` naming ``source`` for the first ``RELATIONS`` rule ``params`` breaks."""
    for rule in getattr(type(params), "RELATIONS", ()):
        problem = rule.problem(params)
        if problem is not None:
            raise InputError(f"{source}: parameter {problem}")


def _key(field: dataclasses.Field) -> str:
    return field.metadata.get("key") or field.name


def param_fields(params_type: type) -> dict[str, dataclasses.Field]:
    """External key -> dataclass field, in declaration order."""
    return {_key(f): f for f in dataclasses.fields(params_type)}


def params_to_dict(params: Any) -> dict[str, Any]:
    """The parameters under their external keys, as recorded in reports."""
    return {_key(f): getattr(params, f.name) for f in dataclasses.fields(params)}


# Integers go to OpenCV and GTSAM as C ints.
INT_MAX = 2**31 - 1


@cache
def schema(params_type: type):
    """A pydantic model of ``params_type``'s fields under their external keys, with the declared
    choices and bounds; every number must be finite, every integer fit a C int. It validates
    strictly (no ``true`` for a number, no text for a number): command-line text is converted
    by :func:`from_text` first."""
    import pydantic  # only where parameters are checked: it adds to every command's start-up
    from pydantic_core import PydanticCustomError

    def one_of(choices: tuple):
        def check(value):
            if value not in choices:
                raise PydanticCustomError("literal_error", "not one of the choices")
            return value
        return pydantic.AfterValidator(check)

    hints = typing.get_type_hints(params_type)
    fields = {}
    for field in dataclasses.fields(params_type):
        kind = hints[field.name]
        choices = field.metadata.get("choices")
        bounds = dict(field.metadata.get("bounds") or {})
        if kind is int and "le" not in bounds and "lt" not in bounds:
            bounds["le"] = INT_MAX
        if kind is int and "ge" not in bounds and "gt" not in bounds:
            bounds["ge"] = -INT_MAX
        # The type first (strict: a bool is no int), then the choices.
        annotation = typing.Annotated[kind, one_of(tuple(choices))] if choices else kind
        numeric = {"allow_inf_nan": False} if kind is float else {}
        fields[field.name] = (annotation, pydantic.Field(field.default, alias=_key(field), **bounds, **numeric))
    config = pydantic.ConfigDict(extra="forbid", populate_by_name=False, strict=True)
    return pydantic.create_model(f"{params_type.__name__}Schema", __config__=config, **fields)


def from_text(params_type: type, key: str, text: str) -> Any:
    """Command-line text as the value of parameter ``key``, read as the same value in a TOML
    config would be: ``5`` an integer, ``0.5``/``1e-3``/``inf`` a number, ``true``/``false``
    (any case) a bool. Text that does not read as the field's type is returned as it is, for
    validation to refuse with the parameter's own message."""
    kind = typing.get_type_hints(params_type)[param_fields(params_type)[key].name]
    text = text.strip()
    if kind is bool:
        return {"true": True, "false": False}.get(text.lower(), text)
    if kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            return text
    return text


_EXPECTED = {"int": "expects an integer", "float": "expects a number", "bool": "expects true or false",
             "string": "expects text", "finite": "expects a finite number"}


def _problem(error, params_type: type) -> str:
    """``KEY problem, got VALUE`` for the first problem of a validation error, in our one-line style."""
    detail = error.errors()[0]
    key = str(detail["loc"][0]) if detail["loc"] else "?"
    kind = detail["type"]
    if kind == "literal_error":
        problem = "must be one of " + ", ".join(map(str, param_fields(params_type)[key].metadata["choices"]))
    elif kind.split("_")[0] in _EXPECTED:
        problem = _EXPECTED[kind.split("_")[0]]
    else:  # a bound: "Input should be greater than 0"
        problem = detail["msg"].replace("Input should be", "must be")
    return f"{key} {problem}, got {detail['input']!r}"


def apply_overrides(params: Any, overrides: dict[str, Any], source: str, relations: bool = True, *,
                    text: bool = False) -> Any:
    """A copy of ``params`` with ``overrides`` (external key -> value) applied and checked.

    Values are of the field's type (a float field takes an int too), as a TOML config gives
    them; with ``text``, they are command-line text, read by :func:`from_text` first. Unknown
    keys and values of the wrong type or outside the declared choices and bounds raise
    :class:`InputError` naming ``source`` and the key (for unknown keys, the valid keys); so does a broken ``RELATIONS`` rule, unless ``relations`` is False (more layers to come).
    """
    fields = param_fields(type(params))
    for key in overrides:
        if key not in fields:
            raise InputError(f"{source}: unknown parameter {key!r}; valid: {', '.join(fields)}")
    import pydantic

    if text:
        overrides = {key: from_text(type(params), key, value) for key, value in overrides.items()}
    values = params_to_dict(params) | dict(overrides)
    try:
        checked = schema(type(params)).model_validate(values)
    except pydantic.ValidationError as error:
        raise InputError(f"{source}: parameter {_problem(error, type(params))}") from None
    result = dataclasses.replace(params, **{name: getattr(checked, name) for name in type(checked).model_fields})
    if relations:
        check_relations(result, source)
    return result


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
    except IsADirectoryError:
        raise InputError.at(path, "is a folder, not a TOML file") from None
    except UnicodeDecodeError as error:
        raise InputError.at(path, f"cannot read config: not UTF-8 text (byte {error.start})") from None
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise InputError.at(path, f"cannot read config: {error}") from None


def resolve_params(params_types: dict[str, type], assignments: Sequence[str] = (), config: Path | None = None) -> dict[str, Any]:
    """Parameters per pipeline from defaults, then ``config``, then ``--param`` assignments.

    A config table named after a pipeline applies to it alone; flat keys and ``--param``
    keys apply to every selected pipeline that has them, and a key that none of them has
    is an error listing the valid keys.
    """
    resolved = {name: kind() for name, kind in params_types.items()}
    layers: list[tuple[str, dict[str, Any], bool]] = []  # (source, values, command-line text)
    if config is not None:
        data = load_config(config)
        for table in (key for key, value in data.items() if isinstance(value, dict) and key not in params_types):
            close = difflib.get_close_matches(table, params_types, n=1)
            hint = f"did you mean [{close[0]}]? " if close else ""
            raise InputError.at(config, f"table [{table}] names no selected pipeline; {hint}"
                                f"tables: {', '.join(f'[{name}]' for name in params_types)}")
        for name in params_types:
            table = data.get(name)
            if isinstance(table, dict):
                resolved[name] = apply_overrides(resolved[name], table, str(config), relations=False)
        flat = {k: v for k, v in data.items() if not isinstance(v, dict)}
        layers.append((str(config), flat, False))
    layers.append(("--param", parse_assignments(list(assignments)), True))
    for source, values, text in layers:
        for key, value in values.items():
            owners = [name for name, kind in params_types.items() if key in param_fields(kind)]
            if not owners:
                valid = sorted({k for kind in params_types.values() for k in param_fields(kind)})
                raise InputError(f"{source}: unknown parameter {key!r} for {', '.join(params_types)}; valid: {', '.join(valid)}")
            for name in owners:
                resolved[name] = apply_overrides(resolved[name], {key: value}, source, relations=False,
                                                 text=text)
    sources = [str(config)] * (config is not None) + ["--param"] * bool(assignments)
    for params in resolved.values():  # on the final values: one layer may set what another relies on
        check_relations(params, " and ".join(sources) or "the defaults")
    return resolved
