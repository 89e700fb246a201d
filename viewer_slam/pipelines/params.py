"""Pipeline parameters: pydantic models whose fields carry the original systems' names.

A pipeline declares its parameters once, as a subclass of :class:`PipelineParams` with one
field per parameter. The attribute is what the pipeline's code reads; the field's ``alias``
is the original system's name (``Odom/ResetCountdown`` for RTAB-Map; RGB-D SLAM's names are
the attributes themselves), which users type on the command line (``--param KEY=VALUE``) and
in TOML configs, and under which reports record the value. Bounds (``ge``, ``gt``, ``le``,
``lt``), choices (a ``Literal``) and the ``description`` are what validation,
``viewslam pipelines`` and the docs read; a rule between two parameters is a model validator
calling :func:`check_ordered`.
"""

import difflib
import typing
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError, ValidationInfo, field_validator
from pydantic.fields import FieldInfo
from pydantic_core import PydanticCustomError

from ..documents import read_toml
from ..errors import InputError

# Integers go to OpenCV and GTSAM as C ints.
INT_MAX = 2**31 - 1
CONFIG_BYTES = 2**20
"""A parameter file holds a few dozen values: a larger one is no config."""


def _exact_int(value: Any) -> Any:
    if type(value) is not int:
        raise PydanticCustomError("int_type", "Input should be a valid integer")
    return value


EXACT_INT = BeforeValidator(_exact_int)
"""For a ``Literal`` of integers: ``true`` and ``6.0`` are no integer choice (a ``Literal``
alone compares by equality, so it takes ``true`` for ``1``)."""


P = typing.TypeVar("P", bound=BaseModel)


class PipelineParams(BaseModel):
    """The base of every pipeline's parameters.

    Validation is strict, as TOML types are: no ``true`` for a number, no text for a number,
    no fraction for an integer; every number is finite, every integer a C int (checked after
    the field's own bounds, and not shown among them). Command-line text is read as the
    field's type by :func:`from_text` first. The parameters of a run never change, so the
    model is frozen.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True, strict=True, allow_inf_nan=False)

    TRACKING_MINIMUM: ClassVar[str | None] = None
    """The attribute holding the matches or inliers a frame needs to be tracked, where the
    pipeline has one: diagnosis measures a lost frame's counts against it."""

    def tracking_minimum(self) -> int | None:
        return None if self.TRACKING_MINIMUM is None else int(getattr(self, self.TRACKING_MINIMUM))

    @field_validator("*")
    @classmethod
    def _fits_c_int(cls, value: Any) -> Any:
        if type(value) is int and value > INT_MAX:
            raise PydanticCustomError("less_than_equal", "Input should be less than or equal to {le}", {"le": INT_MAX})
        if type(value) is int and value < -INT_MAX:
            raise PydanticCustomError(
                "greater_than_equal", "Input should be greater than or equal to {ge}", {"ge": -INT_MAX}
            )
        return value


def check_ordered(
    params: P, info: ValidationInfo, lower: str, upper: str, *, strict: bool = True, off: float | None = None
) -> P:
    """``params`` if parameter ``lower`` is below ``upper`` (at most equal to it when not
    ``strict``) or ``upper`` is ``off`` (a value that means "no limit"): the body of a model's
    ``model_validator(mode="after")`` for a rule between two parameters.

    The rule is skipped when validation's context says ``relations: False``: a value given
    in one layer of the settings (a config) may rely on one given in a later layer (``--param``),
    so :func:`resolve_params` checks relations on the final values only.
    """
    if not (info.context or {}).get("relations", True):
        return params
    low, high = getattr(params, lower), getattr(params, upper)
    if high == off or (low < high if strict else low <= high):
        return params
    fields = type(params).model_fields
    relation = "above" if strict else "at least"
    unless = f", or {off:g} for no limit" if off is not None else ""
    raise invalid(
        f"{key_of(upper, fields[upper])} must be {relation} {key_of(lower, fields[lower])} ({low}){unless}, got {high}"
    )


def invalid(problem: str) -> PydanticCustomError:
    """A validation error whose message is the whole problem, keys and values named: a broken
    rule between parameters, a value refused for a reason of its own."""
    return PydanticCustomError("parameter_problem", "{problem}", {"problem": problem})


def key_of(name: str, field: FieldInfo) -> str:
    return field.alias or name


def keyed_fields(params_type: type[BaseModel]) -> dict[str, FieldInfo]:
    """External key -> field, in declaration order."""
    return {key_of(name, field): field for name, field in params_type.model_fields.items()}


def choices_of(field: FieldInfo) -> tuple[Any, ...]:
    """The values a ``Literal`` field allows; empty for any other field."""
    return typing.get_args(field.annotation) if typing.get_origin(field.annotation) is Literal else ()


def kind_of(field: FieldInfo) -> type:
    """The field's value type (``int`` for a ``Literal`` of integers)."""
    choices = choices_of(field)
    return type(choices[0]) if choices else typing.cast(type, field.annotation)


def bounds_of(field: FieldInfo) -> dict[str, float]:
    """The field's declared bounds by name (``ge``, ``gt``, ``le``, ``lt``); integers are also
    within the C int range (:data:`INT_MAX`)."""
    return {
        name: getattr(item, name)
        for item in field.metadata
        for name in ("ge", "gt", "le", "lt")
        if getattr(item, name, None) is not None
    }


def from_text(field: FieldInfo, text: str) -> Any:
    """Command-line text as the value of ``field``, read as the same value in a TOML config
    would be: ``5`` an integer, ``0.5``/``1e-3``/``inf`` a number, ``true``/``false`` (any case)
    a bool. Text that does not read as the field's type is returned as it is, for validation
    to refuse with the parameter's own message."""
    kind = kind_of(field)
    text = text.strip()
    if kind is bool:
        return {"true": True, "false": False}.get(text.lower(), text)
    if kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            return text
    return text


_EXPECTED = {int: "expects an integer", float: "expects a number", bool: "expects true or false", str: "expects text"}
_TYPE_ERRORS = {"int": int, "float": float, "bool": bool, "string": str}


def problem_of(error: ValidationError, params_type: type[BaseModel]) -> str:
    """``KEY problem, got VALUE`` for the first problem of a validation error, in our one-line style."""
    detail = error.errors()[0]
    kind = detail["type"]
    if kind == "parameter_problem":
        return str(detail["ctx"]["problem"])
    if not detail["loc"]:  # a rule of the model's own, whose message says it all
        return str(detail["msg"]).removeprefix("Value error, ")
    key = str(detail["loc"][0])
    value = detail["input"]
    if kind == "literal_error":
        choices = choices_of(keyed_fields(params_type)[key])
        expected = type(choices[0])  # the type first, as for any other field, then the choices
        problem = _EXPECTED.get(expected, "") if type(value) is not expected else ""
        problem = problem or "must be one of " + ", ".join(map(str, choices))
    elif kind == "finite_number":
        problem = "expects a finite number"
    elif kind.split("_")[0] in _TYPE_ERRORS:
        problem = _EXPECTED[_TYPE_ERRORS[kind.split("_")[0]]]
    else:  # a bound: "Input should be greater than 0"
        problem = detail["msg"].replace("Input should be", "must be")
    return f"{key} {problem}, got {value!r}"


def apply_overrides(
    params: P, overrides: dict[str, Any], source: str, relations: bool = True, *, text: bool = False
) -> P:
    """A copy of ``params`` with ``overrides`` (external key -> value) applied and checked.

    Values are of the field's type (a float field takes an int too), as a TOML config gives
    them; with ``text``, they are command-line text, read by :func:`from_text` first. Unknown
    keys and values of the wrong type or outside the declared choices and bounds raise
    :class:`InputError` naming ``source`` and the key (for unknown keys, the valid keys); so
    does a broken rule between parameters, unless ``relations`` is False (more layers to come).
    """
    fields = keyed_fields(type(params))
    for key in overrides:
        if key not in fields:
            raise InputError(f"{source}: unknown parameter {key!r}; valid: {', '.join(fields)}")
    if text:
        overrides = {key: from_text(fields[key], value) for key, value in overrides.items()}
    return _validated(type(params), params.model_dump(by_alias=True) | overrides, source, relations)


def _validated(params_type: type[P], values: dict[str, Any], source: str, relations: bool = True) -> P:
    try:
        return params_type.model_validate(values, context={"relations": relations})
    except ValidationError as error:
        raise InputError(f"{source}: parameter {problem_of(error, params_type)}") from None


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
    return read_toml(path, "config", max_bytes=CONFIG_BYTES)


def resolve_params(
    params_types: dict[str, type[BaseModel]], assignments: Sequence[str] = (), config: Path | None = None
) -> dict[str, BaseModel]:
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
            raise InputError.at(
                config,
                f"table [{table}] names no selected pipeline; {hint}"
                f"tables: {', '.join(f'[{name}]' for name in params_types)}",
            )
        for name in params_types:
            section = data.get(name)
            if isinstance(section, dict):
                resolved[name] = apply_overrides(resolved[name], section, str(config), relations=False)
        flat = {k: v for k, v in data.items() if not isinstance(v, dict)}
        layers.append((str(config), flat, False))
    layers.append(("--param", parse_assignments(list(assignments)), True))
    for source, values, text in layers:
        for key, value in values.items():
            owners = [name for name, kind in params_types.items() if key in keyed_fields(kind)]
            if not owners:
                valid = sorted({k for kind in params_types.values() for k in keyed_fields(kind)})
                raise InputError(
                    f"{source}: unknown parameter {key!r} for {', '.join(params_types)}; valid: {', '.join(valid)}"
                )
            for name in owners:
                resolved[name] = apply_overrides(resolved[name], {key: value}, source, relations=False, text=text)
    sources = [str(config)] * (config is not None) + ["--param"] * bool(assignments)
    # Relations on the final values: one layer may set what another relies on.
    return {
        name: _validated(type(params), params.model_dump(by_alias=True), " and ".join(sources) or "the defaults")
        for name, params in resolved.items()
    }


_REPLACED = {
    "param": 'a field of a PipelineParams subclass: `name: int = Field(5, alias="Original/Name", ge=0, '
    "description=...)`",
    "Ordered": 'a model_validator(mode="after") that calls check_ordered',
    "check_relations": 'a model_validator(mode="after") that calls check_ordered',
    "param_fields": "keyed_fields",
    "params_to_dict": "params.model_dump(by_alias=True)",
}
"""The parameter API before parameters were pydantic models, and what replaced each name."""


def __getattr__(name: str) -> Any:
    """A plugin written against the earlier API fails to import in one line saying what replaced it."""
    if name in _REPLACED:
        raise ImportError(
            f"{__name__}.{name} is gone: pipeline parameters are a pydantic model now; use "
            f"{_REPLACED[name]} (docs/plugins.md)"
        )
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
