from dataclasses import dataclass

import pytest

from viewer_slam.errors import InputError
from viewer_slam.pipelines.params import apply_overrides, param, params_to_dict, resolve_params


@dataclass(frozen=True)
class OdometryParams:
    reset_countdown: int = param(0, key="Odom/ResetCountdown")
    nndr: float = param(0.8, key="Vis/CorNNDR")
    proximity: bool = param(True, key="RGBD/ProximityBySpace")
    detector: str = param("GFTT_ORB", key="Kp/Detector", choices=("GFTT_ORB", "GFTT_BRIEF"))


@dataclass(frozen=True)
class GraphParams:
    predecessor_candidates: int = param(4)
    nndr: float = param(0.95, key="nn_distance_ratio")


TYPES = {"odometry": OdometryParams, "graph": GraphParams}


def test_keys_and_conversion():
    params = apply_overrides(OdometryParams(), {"Odom/ResetCountdown": "5", "Vis/CorNNDR": "0.7",
                                                "RGBD/ProximityBySpace": "false"}, "--param")
    assert params_to_dict(params) == {"Odom/ResetCountdown": 5, "Vis/CorNNDR": 0.7,
                                      "RGBD/ProximityBySpace": False, "Kp/Detector": "GFTT_ORB"}


@pytest.mark.parametrize("key, value, message", [
    ("Odom/ResetCountdown", "1.5", "expects an integer"),
    ("Vis/CorNNDR", "high", "expects a number"),
    ("RGBD/ProximityBySpace", "maybe", "expects true or false"),
    ("Kp/Detector", "SURF", "must be one of GFTT_ORB, GFTT_BRIEF"),
])
def test_wrong_types_are_rejected(key, value, message):
    with pytest.raises(InputError, match=message):
        apply_overrides(OdometryParams(), {key: value}, "--param")


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
    with pytest.raises(InputError, match=r"^--param: parameter max_matches must be at least min_matches \(400\), got 300$"):
        resolve_params(types, ["min_matches=400"])
    with pytest.raises(InputError, match="maximum_depth must be above minimum_depth"):
        apply_overrides(RgbdSlamParams(), {"minimum_depth": 1.0, "maximum_depth": 1.0}, "benchmark")
