"""What the odometry's bundle adjustment is given: each point's sampled key-frame references."""

import numpy as np
import pytest

from viewer_slam.backend.local_bundle import FREE_FRAME
from viewer_slam.pipelines.rtabmap.bundle import bundle_observations, sampled


@pytest.mark.parametrize("max_frames", [0, 1, 2, 3, 10])
def test_observations_are_each_points_sampled_references_in_order_then_the_frames_own(max_frames):
    """Row by row, to the bit, the observations listed one reference at a time: every point's
    sampled references (few or many, from 1 to 40 key frames), then the adjusted frame's."""
    rng = np.random.default_rng(max_frames)
    references = [
        [
            (int(frame), *rng.uniform(0, 640, 2).tolist(), float(rng.choice([np.nan, rng.uniform(0.5, 4)])))
            for frame in np.sort(rng.choice(100, int(rng.integers(1, 41)), replace=False))
        ]
        for _ in range(300)
    ]
    pixels, depth = rng.uniform(0, 640, (300, 2)), rng.uniform(0.5, 4, 300)
    observations = bundle_observations(references, pixels, depth, max_frames)
    rows = [(index, *reference) for index, point in enumerate(references) for reference in sampled(point, max_frames)]
    rows += [(index, FREE_FRAME, u, v, z) for index, ((u, v), z) in enumerate(zip(pixels.tolist(), depth.tolist()))]
    expected = np.array(rows)
    assert np.array_equal(observations.point, expected[:, 0].astype(int))
    assert np.array_equal(observations.frame, expected[:, 1].astype(int))
    assert np.array_equal(observations.pixels, expected[:, 2:4])
    assert np.array_equal(observations.depth, expected[:, 4], equal_nan=True)
    assert observations.point.dtype == observations.frame.dtype == np.int64


def test_a_point_with_many_references_keeps_every_kth_and_the_newest():
    references = [[(frame, 0.0, 0.0, 1.0) for frame in range(10)]]
    observations = bundle_observations(references, np.zeros((1, 2)), np.ones(1), 3)
    assert observations.frame.tolist() == [0, 3, 6, 9, FREE_FRAME]
    observations = bundle_observations([references[0][:7]], np.zeros((1, 2)), np.ones(1), 3)
    assert observations.frame.tolist() == [0, 2, 4, 6, FREE_FRAME]
