"""Signals measured on frames and tracker events, and the loss entries built from them."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.dataset.frame import Frame
from viewer_slam.diagnosis import (
    DYNAMIC_SHARE_METRIC,
    DiagnosisThresholds,
    MeasuredImages,
    SignalRecorder,
    diagnose_losses,
)
from viewer_slam.diagnosis import signals as signals_module
from viewer_slam.diagnosis.signals import groundtruth_motion, measure_image
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.pipelines.events import FrameTracked, TrackingStatus

RNG = np.random.default_rng(0)
TEXTURED = RNG.integers(0, 256, (240, 320, 3), dtype=np.uint8)
DEPTH = np.full((240, 320), 2.0, dtype=np.float32)


def frame(index: int, rgb=TEXTURED, depth=DEPTH) -> Frame:
    return Frame(index, 10.0 + index / 30, rgb, depth)


def test_a_black_frame_without_depth_is_uniform_cornerless_and_depthless():
    signals = measure_image(frame(0, np.zeros_like(TEXTURED), np.zeros_like(DEPTH)))
    assert (signals.corners, signals.color_std, signals.uniform_share, signals.valid_depth_share) == (0, 0.0, 1.0, 0.0)


def test_a_textured_frame_has_corners_spread_and_the_depth_share_it_holds():
    depth = DEPTH.copy()
    depth[:, :80] = 0.0  # a quarter without measurement
    depth[:60, 80:] = np.nan
    signals = measure_image(frame(0, TEXTURED, depth))
    assert signals.corners > 100 and signals.color_std > 20 and signals.uniform_share < 0.2
    assert signals.valid_depth_share == pytest.approx(1 - 0.25 - 0.25 * 0.75)


@pytest.mark.parametrize("levels", [(0, 255), (3, 250, 128, 137), tuple(range(256)), (9, 10), (100,)])
@pytest.mark.parametrize("shape", [(6, 8), (5, 7), (1, 1), (2, 1)])
def test_the_uniform_share_counted_on_the_histogram_is_the_sorted_median_s_to_the_bit(levels, shape):
    """Even and odd counts, a median halfway between two levels, levels at the range's ends."""
    rng = np.random.default_rng(len(levels) * 100 + shape[0])
    for _ in range(50):
        grey = rng.choice(np.array(levels, dtype=np.uint8), shape)
        as_float = grey.astype(np.float32)
        sorted_median = float(np.mean(np.abs(as_float - np.median(as_float)) <= signals_module.UNIFORM_TOLERANCE))
        assert signals_module._uniform_share(grey) == sorted_median


def test_groundtruth_motion_is_speed_and_rotation_rate_between_frames():
    stamps = np.arange(5) / 10.0
    poses = np.tile(np.eye(4), (5, 1, 1))
    poses[:, 0, 3] = 0.2 * np.arange(5)  # 2 m/s along x
    poses[:, :3, :3] = Rotation.from_rotvec(np.outer(0.05 * np.arange(5), [0, 0, 1])).as_matrix()  # 0.5 rad/s
    speed, rotation_rate = groundtruth_motion(Trajectory(stamps, poses), stamps)
    assert np.isnan(speed[0]) and np.isnan(rotation_rate[0])
    np.testing.assert_allclose(speed[1:], 2.0)
    np.testing.assert_allclose(rotation_rate[1:], 0.5)
    assert np.all(np.isnan(groundtruth_motion(None, stamps)[0]))


def tracked(index: int, pose: bool, features=500, matches=200, inliers=100, metrics=None) -> FrameTracked:
    return FrameTracked(
        index,
        10.0 + index / 30,
        np.eye(4) if pose else None,
        TrackingStatus.OK if pose else TrackingStatus.LOST,
        features,
        matches,
        inliers,
        metrics=metrics or {},
    )


def recorded(frames, events) -> SignalRecorder:
    recorder = SignalRecorder()
    for item in frames:
        recorder.frame(item)
    for event in events:
        recorder(event)
    return recorder


def test_the_recorder_keeps_one_row_per_frame_with_the_tracker_counts_and_residual_share():
    recorder = recorded(
        [frame(i) for i in (0, 2, 4)],
        [tracked(0, True, metrics={DYNAMIC_SHARE_METRIC: 0.4}), tracked(2, False, 30, 10, 0)],
    )
    signals = recorder.signals()
    assert signals.frame_indices.tolist() == [0, 2, 4]
    assert signals.keypoints[:2].tolist() == [500, 30] and np.isnan(signals.keypoints[2])
    assert signals.dynamic_share[0] == 0.4 and np.isnan(signals.dynamic_share[1])
    assert signals.tracked.tolist() == [True, False, False]
    assert signals.position(3) == 2


def test_runs_over_the_same_frames_measure_each_frame_once_and_see_the_same_signals(monkeypatch):
    measured = []
    monkeypatch.setattr(
        signals_module, "measure_image", lambda frame: measured.append(frame.index) or measure_image(frame)
    )
    blank = np.zeros_like(TEXTURED)
    frames = [frame(0), frame(1, blank), frame(2)]
    shared = MeasuredImages()
    first, second = SignalRecorder(shared), SignalRecorder(shared)
    for item in frames:
        first.frame(item)
    for item in frames:  # the same frames read again for the second run
        second.frame(frame(item.index, item.rgb.copy(), item.depth.copy()))
    assert measured == [0, 1, 2]
    alone = recorded(frames, []).signals()
    for recorder in (first, second):
        shared_signals = recorder.signals()
        for name in ("corners", "color_std", "uniform_share", "valid_depth_share"):
            np.testing.assert_array_equal(getattr(shared_signals, name), getattr(alone, name))
    assert alone.corners[1] == 0 < alone.corners[0]


def test_the_window_stops_at_the_next_pose_and_the_medians_are_over_lost_frames_only():
    blank = np.zeros_like(TEXTURED)
    frames = (
        [frame(i) for i in range(3)]
        + [frame(i, blank, np.zeros_like(DEPTH)) for i in range(3, 6)]
        + [frame(i) for i in range(6, 12)]
    )
    events = (
        [tracked(i, True) for i in range(3)]
        + [tracked(i, False, 0, 0, 0) for i in range(3, 6)]
        + [tracked(i, True) for i in range(6, 12)]
    )
    signals = recorded(frames, events).signals()
    loss = {"frame": 3, "timestamp": 10.1, "reason": "test"}
    (entry,) = diagnose_losses("p", [loss], signals, 25, None)
    assert entry["evidence"]["frames"] == 3 and entry["evidence"]["minimum"] == 25
    assert entry["cause"] == "sensor blocked" and entry["causes"][0] == "sensor blocked"
    assert entry["text"] == "p lost at 0.1 s: sensor blocked (colour 100% uniform, 0% valid depth)"
    assert {key: entry[key] for key in loss} == loss
    assert "speed" not in entry["evidence"]  # no groundtruth, no motion evidence


def test_a_loss_far_faster_than_the_run_is_fast_motion():
    frames = [frame(i) for i in range(20)]
    events = [tracked(i, i != 12, inliers=100 if i != 12 else 5) for i in range(20)]
    stamps = 10.0 + np.arange(20) / 30
    poses = np.tile(np.eye(4), (20, 1, 1))
    steps = np.full(20, 0.01)
    steps[12] = 0.1  # one jump ten times the usual step
    poses[:, 0, 3] = np.cumsum(steps)
    (entry,) = diagnose_losses(
        "p",
        [{"frame": 12, "timestamp": stamps[12], "reason": ""}],
        recorded(frames, events).signals(),
        None,
        Trajectory(stamps, poses),
    )
    assert entry["causes"] == ["fast motion", "too few inliers"]
    assert entry["evidence"]["speed_ratio"] == pytest.approx(10.0, rel=1e-6)


def test_the_minimum_is_the_one_the_pipelines_parameters_declare_else_the_default():
    from viewer_slam.pipelines.params import apply_overrides
    from viewer_slam.pipelines.rgbdslam.params import RgbdSlamParams
    from viewer_slam.pipelines.rtabmap.params import RtabmapParams
    from viewer_slam.runs.replay import EstimateParams

    assert apply_overrides(RgbdSlamParams(), {"min_matches": 30}, "test").tracking_minimum() == 30
    assert apply_overrides(RtabmapParams(), {"Vis/MinInliers": 15}, "test").tracking_minimum() == 15
    assert EstimateParams().tracking_minimum() is None
    assert DiagnosisThresholds().default_minimum == 20


def test_a_run_that_never_reports_a_count_has_no_tracker_signals():
    """An estimate replayed from a file reports 0 features everywhere: not measured, not zero."""
    blank = np.zeros_like(TEXTURED)
    frames = [frame(i) for i in range(5)] + [frame(i, blank) for i in range(5, 8)]
    events = [tracked(i, i < 5, 0, 0, 0) for i in range(8)]
    signals = recorded(frames, events).signals()
    assert np.all(np.isnan(signals.keypoints)) and np.all(np.isnan(signals.inliers))
    (entry,) = diagnose_losses("estimate", [{"frame": 5, "timestamp": 10.2, "reason": "gap"}], signals, None, None)
    assert "keypoints" not in entry["evidence"] and entry["evidence"]["minimum"] == 20
    assert entry["cause"] == "too few features"  # from the image: a black frame has no corners
    assert entry["text"].endswith("(0 corners of contrast 20, minimum 20)")
