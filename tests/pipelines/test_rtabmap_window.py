"""The guess window's neighbour test against the k-d tree's ball query it replaces."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from viewer_slam.pipelines.rtabmap.window import has_neighbour_within


def tree_answer(points: np.ndarray, others: np.ndarray, radius: float) -> np.ndarray:
    return cKDTree(others).query_ball_point(points, radius, return_length=True) > 0


@pytest.mark.parametrize("radius", [40.0, 10.0, 3.5, 1e-3])
def test_the_same_points_have_a_corner_within_the_window_as_the_tree_finds(radius):
    """Projections spread over an image and beyond it, the corners at random or on whole
    pixels, and projections placed at the window's edge (exactly, by Pythagorean offsets, and
    within rounding, on a circle): every answer is the tree's."""
    rng = np.random.default_rng(0)
    edge = np.array([[0.6, 0.8], [1.0, 0.0], [0.0, -1.0], [-0.8, 0.6]]) * radius
    for trial in range(300):
        others = rng.uniform(-50, 700, (int(rng.integers(1, 400)), 2))
        count = int(rng.integers(1, 400))
        if trial % 3 == 0:
            others = np.round(others)
            points = others[rng.integers(0, len(others), count)] + edge[rng.integers(0, 4, count)]
        elif trial % 3 == 1:
            angle = rng.uniform(0, 2 * np.pi, count)
            points = others[rng.integers(0, len(others), count)] + radius * np.c_[np.cos(angle), np.sin(angle)]
        else:
            points = rng.uniform(-50, 700, (count, 2))
        assert np.array_equal(has_neighbour_within(points, others, radius), tree_answer(points, others, radius))


def test_the_bound_is_included_and_far_or_no_corners_give_none():
    others = np.array([[0.0, 0.0], [100.0, 100.0]])
    points = np.array([[40.0, 0.0], [24.0, 32.0], [24.0, 32.000000001], [-40.0, 0.0], [1e9, -1e9]])
    assert has_neighbour_within(points, others, 40).tolist() == [True, True, False, True, False]
    assert has_neighbour_within(points, np.zeros((0, 2)), 40).tolist() == [False] * 5
    assert has_neighbour_within(np.zeros((0, 2)), others, 40).shape == (0,)
