"""The share of matched points moving against the camera, against numbers worked out by hand."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.diagnosis import Cause, LossSignals, classify
from viewer_slam.frontend.motion_consistency import inconsistent_share, motion_residuals
from viewer_slam.geometry.se3 import make_pose

# A quarter turn about z and 1 m along x: (x, y, z) -> (1 - y, x, z).
QUARTER_TURN = make_pose(Rotation.from_rotvec([0, 0, np.pi / 2]).as_matrix(), [1.0, 0.0, 0.0])
SOURCE = np.array([[1.0, 0.0, 2.0], [0.0, 1.0, 2.0], [1.0, 1.0, 3.0], [2.0, 0.0, 1.0]])
# Where a static scene puts them: (1, 1, 2), (0, 0, 2), (0, 1, 3), (1, 2, 1).
STATIC = np.array([[1.0, 1.0, 2.0], [0.0, 0.0, 2.0], [0.0, 1.0, 3.0], [1.0, 2.0, 1.0]])


def test_a_static_scene_has_no_residual_and_no_inconsistent_point():
    assert motion_residuals(SOURCE, STATIC, QUARTER_TURN) == pytest.approx(np.zeros(4), abs=1e-12)
    assert inconsistent_share(SOURCE, STATIC, QUARTER_TURN, threshold=0.05) == 0.0


def test_points_displaced_beyond_the_threshold_are_the_share():
    moved = STATIC + np.array([[0.3, 0.4, 0.0], [0.0, 0.0, 0.04], [0.0, 0.06, 0.0], [0.0, 0.0, 0.0]])
    # residuals 0.5 (3-4-5), 0.04, 0.06, 0: two of four exceed 0.05 m
    assert motion_residuals(SOURCE, moved, QUARTER_TURN) == pytest.approx([0.5, 0.04, 0.06, 0.0], abs=1e-12)
    assert inconsistent_share(SOURCE, moved, QUARTER_TURN, threshold=0.05) == 0.5
    # a residual equal to the threshold is consistent (an inlier), as the pipelines' tests are "<="
    assert inconsistent_share(SOURCE, moved, QUARTER_TURN, threshold=0.5) == 0.0


def test_a_threshold_per_point_scales_with_each_pair():
    moved = STATIC + np.array([[0.0, 0.0, 0.1]] * 4)  # every residual 0.1 m
    bounds = np.array([0.05, 0.2, 0.05, 0.2])
    assert inconsistent_share(SOURCE, moved, QUARTER_TURN, threshold=bounds) == 0.5


def test_pairs_without_depth_are_left_out_and_none_left_is_nan():
    moved = STATIC.copy()
    moved[0] += [1.0, 0.0, 0.0]  # inconsistent
    moved[1] = np.nan  # no depth in the second frame
    assert inconsistent_share(SOURCE, moved, QUARTER_TURN, threshold=0.05) == pytest.approx(1 / 3)
    assert math.isnan(inconsistent_share(SOURCE, np.full_like(STATIC, np.nan), QUARTER_TURN, threshold=0.05))
    assert math.isnan(inconsistent_share(np.zeros((0, 3)), np.zeros((0, 3)), QUARTER_TURN, threshold=0.05))


def test_mismatched_arrays_are_refused():
    with pytest.raises(ValueError, match="matched points"):
        motion_residuals(SOURCE, STATIC[:3], QUARTER_TURN)


def test_the_share_reaches_the_diagnosis_as_a_dynamic_scene_at_its_threshold():
    """Three of ten points moving (0.3) meets the default threshold; two (0.2) does not."""
    points = np.column_stack([np.arange(10.0), np.zeros(10), np.full(10, 2.0)])
    for moving, holds in ((3, True), (2, False)):
        target = points.copy()
        target[:moving, 1] += 0.5
        share = inconsistent_share(points, target, np.eye(4), threshold=0.05)
        assert share == moving / 10
        signals = LossSignals(
            frames=1,
            minimum=20,
            corners=500,
            color_std=40,
            uniform_share=0.1,
            valid_depth_share=0.9,
            keypoints=500,
            matches=300,
            inliers=200,
            dynamic_share=share,
        )
        assert (Cause.DYNAMIC_SCENE in [finding.cause for finding in classify(signals)]) is holds
