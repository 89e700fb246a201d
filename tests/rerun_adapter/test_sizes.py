"""Sizes drawn in the 3D view follow the scene's extent; growing snapshots stay in their budget."""

import numpy as np
import pytest

from viewer_slam.rerun_adapter.budget import SnapshotBudget
from viewer_slam.rerun_adapter.sizes import (
    FRUSTUM_RANGE_M,
    FRUSTUM_SHARE,
    KEYFRAME_SHARE,
    MIN_EXTENT_M,
    extent,
    scene_sizes,
)


def test_extent_is_the_largest_side_of_the_bounding_box():
    positions = np.array([[0.0, 0.0, 0.0], [0.27, -0.05, 0.1], [0.1, 0.04, -0.02]])
    assert extent(positions) == pytest.approx(0.27)
    assert extent(np.zeros((0, 3))) == 0.0


def test_sizes_are_shares_of_the_extent_between_their_bounds():
    desk, room = scene_sizes(0.27), scene_sizes(2.0)
    assert room.frustum_depth == pytest.approx(FRUSTUM_SHARE * 2.0)  # 0.24 m: inside the bounds
    assert room.keyframe_radius == pytest.approx(KEYFRAME_SHARE * 2.0)
    assert desk.frustum_depth == pytest.approx(max(FRUSTUM_SHARE * 0.27, FRUSTUM_RANGE_M[0]))
    assert all(d < r for d, r in zip(desk, room))  # a desk is drawn finer than a room
    hall, building = scene_sizes(7.0), scene_sizes(30.0)
    assert hall.frustum_depth == pytest.approx(FRUSTUM_SHARE * 7.0) and hall.frustum_depth > 5 * desk.frustum_depth
    assert building.frustum_depth == FRUSTUM_RANGE_M[1]
    # A frustum stays well inside the scene it is drawn in, and a still camera gets the floor's sizes.
    assert desk.frustum_depth < 0.27 / 2
    assert scene_sizes(0.0) == scene_sizes(MIN_EXTENT_M)


def test_a_thinned_snapshot_is_due_earlier_and_costs_only_what_was_earned():
    whole, thinned = SnapshotBudget(1000), SnapshotBudget(1000, min_share=0.25)
    for budget in (whole, thinned):
        budget.dirty = True
        assert budget.due(0, 10**9) and budget.share(0, 10**9) == 1.0  # the first snapshot is whole
        budget.logged(0)
        budget.dirty = True
    assert not whole.due(30, 100_000) and not thinned.due(24, 100_000)
    assert thinned.due(25, 100_000) and thinned.share(25, 100_000) == pytest.approx(0.25)
    assert thinned.share(250, 100_000) == 1.0 and whole.due(100, 100_000)


def test_thinned_snapshots_of_a_growing_map_stay_in_the_budget_and_refresh_often():
    budget, frames, spent, logged_at = SnapshotBudget(3072, min_share=0.25), 240, 0.0, []
    for frame in range(frames):
        size = 16 * min(40_000, 2_000 * (frame + 1))  # grows, then capped as the voxel map is
        budget.dirty = True
        if budget.due(frame, size):
            spent += budget.share(frame, size) * size
            logged_at.append(frame)
            budget.logged(frame)
    assert spent <= 3072 * frames + 16 * 2_000  # the whole first snapshot comes on top
    assert len(logged_at) >= 5
