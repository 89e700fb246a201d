"""The loss classifier on hand-made signals: each cause on its own, the ranking, and the thresholds."""

import dataclasses
import math

import pytest

from viewer_slam.diagnosis import CAUSE_ORDER, Cause, DiagnosisThresholds, LossSignals, classify

THRESHOLDS = DiagnosisThresholds()
# A frame a pipeline tracks well: textured, depth everywhere, plenty of inliers, ordinary motion.
HEALTHY = LossSignals(
    frames=5,
    minimum=20,
    corners=400,
    color_std=40.0,
    uniform_share=0.2,
    valid_depth_share=0.9,
    keypoints=600,
    matches=300,
    inliers=150,
    dynamic_share=0.05,
    speed=0.3,
    speed_ratio=1.0,
    rotation_rate=0.5,
    rotation_ratio=1.0,
)


def causes(signals: LossSignals, thresholds: DiagnosisThresholds = THRESHOLDS) -> list[Cause]:
    return [finding.cause for finding in classify(signals, thresholds)]


def test_nothing_standing_out_is_unknown():
    assert causes(HEALTHY) == [Cause.UNKNOWN]


def test_a_blocked_sensor_also_has_no_depth_and_ranks_first():
    blocked = dataclasses.replace(HEALTHY, uniform_share=1.0, valid_depth_share=0.0)
    assert causes(blocked) == [Cause.SENSOR_BLOCKED, Cause.NO_DEPTH]


@pytest.mark.parametrize(
    "changes, expected",
    [
        ({"valid_depth_share": 0.1}, Cause.NO_DEPTH),
        ({"speed": 2.0, "speed_ratio": 6.0}, Cause.FAST_MOTION),
        ({"rotation_rate": 3.0, "rotation_ratio": 4.0}, Cause.FAST_MOTION),
        ({"dynamic_share": 0.6}, Cause.DYNAMIC_SCENE),
        ({"keypoints": 12}, Cause.TOO_FEW_FEATURES),
        ({"corners": 3}, Cause.TOO_FEW_FEATURES),
        ({"matches": 40, "inliers": 8}, Cause.TOO_FEW_INLIERS),
    ],
)
def test_each_cause_holds_on_its_own_signal(changes, expected):
    assert causes(dataclasses.replace(HEALTHY, **changes)) == [expected]


def test_a_uniform_colour_with_depth_is_a_blank_wall_not_a_blocked_sensor():
    wall = dataclasses.replace(HEALTHY, uniform_share=0.99, color_std=2.0, corners=0)
    assert causes(wall) == [Cause.TOO_FEW_FEATURES]


def test_causes_that_hold_together_are_ranked_scene_and_sensor_before_tracker_symptoms():
    covered_and_carried = dataclasses.replace(
        HEALTHY,
        uniform_share=1.0,
        valid_depth_share=0.0,
        corners=0,
        keypoints=0,
        matches=0,
        inliers=0,
        speed_ratio=5.0,
        speed=2.0,
    )
    assert causes(covered_and_carried) == [
        Cause.SENSOR_BLOCKED,
        Cause.NO_DEPTH,
        Cause.FAST_MOTION,
        Cause.TOO_FEW_FEATURES,
    ]
    blurred = dataclasses.replace(HEALTHY, rotation_ratio=5.0, rotation_rate=4.0, inliers=5, dynamic_share=0.5)
    assert causes(blurred) == [Cause.FAST_MOTION, Cause.DYNAMIC_SCENE, Cause.TOO_FEW_INLIERS]
    assert CAUSE_ORDER.index(Cause.UNKNOWN) == len(CAUSE_ORDER) - 1


def test_signals_not_measured_never_make_a_cause():
    imported = LossSignals(frames=5, minimum=20, corners=400, color_std=40.0, uniform_share=0.2, valid_depth_share=0.9)
    assert causes(imported) == [Cause.UNKNOWN]
    assert set(imported.evidence()) == {
        "frames",
        "minimum",
        "corners",
        "color_std",
        "uniform_share",
        "valid_depth_share",
    }


def test_thresholds_are_configurable_and_decide_at_their_value():
    borderline = dataclasses.replace(HEALTHY, valid_depth_share=0.3)
    assert causes(borderline) == [Cause.UNKNOWN]
    assert causes(borderline, DiagnosisThresholds(min_depth_share=0.31)) == [Cause.NO_DEPTH]
    at_ratio = dataclasses.replace(HEALTHY, speed_ratio=THRESHOLDS.fast_motion_ratio)
    assert causes(at_ratio) == [Cause.FAST_MOTION]
    assert causes(dataclasses.replace(at_ratio, speed_ratio=math.nextafter(THRESHOLDS.fast_motion_ratio, 0))) == [
        Cause.UNKNOWN
    ]


def test_the_finding_text_quotes_the_measured_numbers_and_the_minimum():
    few = dataclasses.replace(HEALTHY, keypoints=41, minimum=100)
    assert classify(few)[0].text == "41 keypoints, minimum 100"
    inliers = dataclasses.replace(HEALTHY, matches=80, inliers=12)
    assert classify(inliers)[0].text == "12 inliers of 80 matches, minimum 20"
