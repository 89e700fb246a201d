import json
import math
import tempfile
from pathlib import Path
from typing import Annotated, Literal

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import Field

from viewer_slam.errors import InputError
from viewer_slam.pipelines.params import (
    EXACT_INT,
    INT_MAX,
    PipelineParams,
    apply_overrides,
    bounds_of,
    choices_of,
    keyed_fields,
    kind_of,
    resolve_params,
)
from viewer_slam.pipelines.rgbdslam.params import RgbdSlamParams
from viewer_slam.pipelines.rtabmap.params import RtabmapParams


class OdometryParams(PipelineParams):
    reset_countdown: int = Field(0, alias="Odom/ResetCountdown")
    nndr: float = Field(0.8, alias="Vis/CorNNDR")
    proximity: bool = Field(True, alias="RGBD/ProximityBySpace")
    detector: Literal["GFTT_ORB", "GFTT_BRIEF"] = Field("GFTT_ORB", alias="Kp/Detector")


class GraphParams(PipelineParams):
    predecessor_candidates: int = 4
    nndr: float = Field(0.95, alias="nn_distance_ratio")


TYPES = {"odometry": OdometryParams, "graph": GraphParams}


def test_keys_and_conversion():
    params = apply_overrides(
        OdometryParams(),
        {"Odom/ResetCountdown": "5", "Vis/CorNNDR": "0.7", "RGBD/ProximityBySpace": "false"},
        "--param",
        text=True,
    )
    assert params.model_dump(by_alias=True) == {
        "Odom/ResetCountdown": 5,
        "Vis/CorNNDR": 0.7,
        "RGBD/ProximityBySpace": False,
        "Kp/Detector": "GFTT_ORB",
    }


@pytest.mark.parametrize(
    "key, value, message",
    [
        ("Odom/ResetCountdown", "1.5", "expects an integer"),
        ("Vis/CorNNDR", "high", "expects a number"),
        ("RGBD/ProximityBySpace", "maybe", "expects true or false"),
        ("Kp/Detector", "SURF", "must be one of GFTT_ORB, GFTT_BRIEF"),
    ],
)
def test_wrong_types_are_rejected(key, value, message):
    with pytest.raises(InputError, match=message):
        apply_overrides(OdometryParams(), {key: value}, "--param", text=True)


def test_every_integer_is_a_c_int_without_declaring_it():
    with pytest.raises(
        InputError,
        match=rf"^--param: parameter predecessor_candidates must be less than or equal to "
        rf"{INT_MAX}, got {INT_MAX + 1}$",
    ):
        apply_overrides(GraphParams(), {"predecessor_candidates": str(INT_MAX + 1)}, "--param", text=True)
    assert bounds_of(keyed_fields(GraphParams)["predecessor_candidates"]) == {}


def test_a_choice_of_integers_takes_no_bool_and_no_fraction():
    class Choice(PipelineParams):
        mode: Annotated[Literal[0, 1], EXACT_INT] = 1

    for value in (True, 1.0):
        with pytest.raises(InputError, match=r"^c.toml: parameter mode expects an integer, got "):
            apply_overrides(Choice(), {"mode": value}, "c.toml")
    assert apply_overrides(Choice(), {"mode": "0"}, "--param", text=True).mode == 0


def test_resolve_routes_keys_to_their_pipeline_and_config_tables(tmp_path):
    config = tmp_path / "study.toml"
    config.write_text('predecessor_candidates = 6\n[odometry]\n"Odom/ResetCountdown" = 3\n')
    resolved = resolve_params(TYPES, ["nn_distance_ratio=0.9"], config)
    assert resolved["odometry"].reset_countdown == 3
    assert resolved["graph"].predecessor_candidates == 6
    assert resolved["graph"].nndr == 0.9
    assert resolved["odometry"].nndr == 0.8


def test_unknown_key_lists_valid_keys():
    with pytest.raises(InputError) as error:
        resolve_params(TYPES, ["Odom/Nope=1"])
    message = str(error.value)
    assert "unknown parameter 'Odom/Nope'" in message and "predecessor_candidates" in message
    assert "\n" not in message


def test_assignment_without_equals_sign():
    with pytest.raises(InputError, match="expected KEY=VALUE"):
        resolve_params(TYPES, ["predecessor_candidates"])


def test_unreadable_config_names_the_file(tmp_path):
    config = tmp_path / "broken.toml"
    config.write_text("predecessor_candidates = = 3\n")
    with pytest.raises(InputError, match="broken.toml"):
        resolve_params(TYPES, [], config)


def test_a_relation_is_checked_on_the_final_values_and_an_off_value_lifts_it():
    from viewer_slam.pipelines.rgbdslam import RgbdSlamParams

    types = {"rgbdslam": RgbdSlamParams}
    # 400 is above the default cap of 300 matches; the next assignment raises the cap.
    resolved = resolve_params(types, ["min_matches=400", "max_matches=500"])["rgbdslam"]
    assert (resolved.min_matches, resolved.max_matches) == (400, 500)
    assert resolve_params(types, ["minimum_depth=5", "maximum_depth=0"])["rgbdslam"].minimum_depth == 5
    with pytest.raises(
        InputError, match=r"^--param: parameter max_matches must be at least min_matches \(400\), got 300$"
    ):
        resolve_params(types, ["min_matches=400"])
    with pytest.raises(InputError, match="maximum_depth must be above minimum_depth"):
        apply_overrides(RgbdSlamParams(), {"minimum_depth": 1.0, "maximum_depth": 1.0}, "benchmark")


# --param and --config accept exactly the same values, for every parameter of every pipeline.

PIPELINES = {"rgbdslam": RgbdSlamParams, "rtabmap": RtabmapParams}
DECLARED = [
    (pipeline, key, kind_of(field), field)
    for pipeline, kind in PIPELINES.items()
    for key, field in keyed_fields(kind).items()
]


def as_text(value) -> str:
    """How a user types ``value`` after ``--param KEY=``."""
    return str(value).lower() if isinstance(value, bool) else repr(value) if isinstance(value, float) else str(value)


def as_toml(value) -> str:
    return (
        str(value).lower() if isinstance(value, bool) else json.dumps(value) if isinstance(value, str) else repr(value)
    )


def limits(kind: type, field) -> tuple[float, float, bool, bool]:
    """(low, high, low included, high included) of a number parameter, the C int range included."""
    bounds = bounds_of(field)
    low, low_in = (
        (bounds["ge"], True)
        if "ge" in bounds
        else (bounds["gt"], False)
        if "gt" in bounds
        else ((-INT_MAX, True) if kind is int else (-math.inf, False))
    )
    high, high_in = (
        (bounds["le"], True)
        if "le" in bounds
        else (bounds["lt"], False)
        if "lt" in bounds
        else ((INT_MAX, True) if kind is int else (math.inf, False))
    )
    return low, high, low_in, high_in


def allowed_values(kind: type, field) -> list:
    """Every choice, both bools, and each bound's edge (the last allowed value on each side)."""
    if choices_of(field):
        return list(choices_of(field))
    if kind is bool:
        return [True, False]
    if kind is str:
        return []
    low, high, low_in, high_in = limits(kind, field)
    step = (lambda x, towards: x + (1 if towards > x else -1)) if kind is int else math.nextafter
    edges = [low if low_in else step(low, high), high if high_in else step(high, low)]
    return [kind(edge) for edge in edges if math.isfinite(edge)]


def refused_values(kind: type, field) -> list:
    """The first value past each bound, a value outside the choices, a bool for a number."""
    refused = [True] if kind in (int, float) else []
    if choices_of(field):
        return refused + [max(choices_of(field)) + 1 if kind is int else "NOT_A_CHOICE"]
    if kind in (int, float):
        low, high, low_in, high_in = limits(kind, field)
        step = (lambda x, towards: x + (1 if towards > x else -1)) if kind is int else math.nextafter
        refused += [
            kind(step(low, -math.inf) if low_in else low) if math.isfinite(low) else None,
            kind(step(high, math.inf) if high_in else high) if math.isfinite(high) else None,
        ]
    return [value for value in refused if value is not None]


_CONFIG_FOLDER = tempfile.TemporaryDirectory()


def both_ways(pipeline: str, key: str, value) -> tuple:
    """What ``--param KEY=VALUE`` and a config ``"KEY" = VALUE`` give: the parameters, or the
    problem (the message between its source and the value as typed)."""
    config = Path(_CONFIG_FOLDER.name) / "params.toml"
    config.write_text(f"{json.dumps(key)} = {as_toml(value)}\n")
    outcomes = []
    for assignments, path in (([f"{key}={as_text(value)}"], None), ([], config)):
        try:
            outcomes.append(resolve_params({pipeline: PIPELINES[pipeline]}, assignments, path)[pipeline])
        except InputError as error:
            outcomes.append(str(error).split(": ", 1)[1].rsplit(", got ", 1)[0])
    return tuple(outcomes)


@pytest.mark.parametrize(
    "pipeline, key, value",
    [(p, key, value) for p, key, kind, field in DECLARED for value in allowed_values(kind, field)],
)
def test_every_allowed_value_and_bound_edge_is_accepted_alike_by_param_and_config(pipeline, key, value):
    by_param, by_config = both_ways(pipeline, key, value)
    assert by_param == by_config
    if isinstance(by_param, PipelineParams):  # else a relation with another parameter's default refuses it
        dumped = by_param.model_dump(by_alias=True)
        assert type(dumped[key]) is type(value) and dumped[key] == value


@pytest.mark.parametrize(
    "pipeline, key, value",
    [(p, key, value) for p, key, kind, field in DECLARED for value in refused_values(kind, field)],
)
def test_every_value_past_a_bound_or_choice_is_refused_alike_by_param_and_config(pipeline, key, value):
    by_param, by_config = both_ways(pipeline, key, value)
    assert isinstance(by_param, str) and by_param == by_config and by_param.startswith(f"parameter {key} ")


def values_of(kind: type, field):
    if choices_of(field):
        return st.sampled_from(choices_of(field))
    if kind is bool:
        return st.booleans()
    if kind is str:
        return st.text(alphabet="abcdefgh_", min_size=1)
    low, high, low_in, high_in = limits(kind, field)
    if kind is int:
        return st.integers(-INT_MAX - 10, INT_MAX + 10)
    return st.floats(allow_nan=False, allow_infinity=False) | st.floats(
        min_value=max(low, -1e6), max_value=min(high, 1e6)
    )


@st.composite
def declared_values(draw):
    pipeline, key, kind, field = draw(st.sampled_from(DECLARED))
    return pipeline, key, draw(values_of(kind, field) | st.booleans())


@settings(max_examples=120, deadline=None)
@given(declared_values())
def test_param_and_config_agree_on_any_value(drawn):
    pipeline, key, value = drawn
    by_param, by_config = both_ways(pipeline, key, value)
    if isinstance(by_param, str) or isinstance(by_config, str):  # refused both ways (``false`` is text on the
        assert isinstance(by_param, str) and isinstance(by_config, str)  # command line, a bool in TOML)
    else:
        assert by_param == by_config
