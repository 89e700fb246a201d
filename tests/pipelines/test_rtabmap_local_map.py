"""The local map's bookkeeping: the counts of references per key frame and the points kept."""

from collections import Counter

import numpy as np

from viewer_slam.pipelines.rtabmap.odometry import LocalMap, all_but


def test_all_but_is_the_set_difference_from_every_index():
    rng = np.random.default_rng(0)
    for count in (0, 1, 5, 100, 2500):
        for _ in range(50):
            indices = rng.integers(0, count, int(rng.integers(0, 3 * count + 1))) if count else np.zeros(0, int)
            expected = np.setdiff1d(np.arange(count), indices)
            found = all_but(indices, count)
            assert found.dtype == expected.dtype and np.array_equal(found, expected)


def test_the_counts_per_key_frame_stay_those_of_the_references_through_adds_observations_and_caps():
    """Forty key frames of a map capped at 300 points: after every step the count of each key
    frame is the number of references to it, and a key frame no point refers to is not counted."""
    rng = np.random.default_rng(1)
    local_map = LocalMap()
    for frame in range(40):
        observed = rng.choice(len(local_map), min(len(local_map), 60), replace=False) if len(local_map) else []
        local_map.refer(np.asarray(observed, int), [(frame, 0.0, 0.0, 1.0)] * len(observed))
        added = int(rng.integers(0, 120))
        local_map.add(
            rng.normal(size=(added, 3)),
            rng.integers(0, 256, (added, 32), dtype=np.uint8),
            frame,
            [(frame, float(i), 0.0, 1.0) for i in range(added)],
        )
        inliers = rng.choice(len(local_map), min(len(local_map), 50), replace=False)
        local_map.cap(300, rng.choice(len(local_map), 30), inliers, added)
        expected = Counter(reference[0] for point in local_map.references for reference in point)
        assert local_map.referenced == expected and all(count > 0 for count in local_map.referenced.values())
        assert len(local_map) <= max(300, added - 1)
