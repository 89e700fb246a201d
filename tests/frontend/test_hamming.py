"""Compiled matching of binary descriptors (ratio test, nearest neighbour under a bound, guided
by image position) against distances counted by hand."""

import numpy as np
from binary_descriptors import descriptors

from viewer_slam.frontend.features import match_with_ratios
from viewer_slam.frontend.hamming import (
    PackedDescriptors,
    hamming_nearest_matches,
    hamming_ratio_matches,
    nearest_within_radius,
)


def test_nearest_over_second_nearest_distance_is_the_ratio():
    # query 0 bits; train rows at 3, 5 and 70 bits: nearest 3, second 5, ratio 0.6
    query, train = descriptors(0), descriptors(70, 3, 5)
    q, t, ratios = hamming_ratio_matches(query, train, 0.95)
    assert q.tolist() == [0] and t.tolist() == [1] and ratios.tolist() == [0.6]
    assert len(hamming_ratio_matches(query, train, 0.6)[0]) == 0  # 3 < 0.6 * 5 fails


def test_a_train_row_goes_to_its_nearest_query_and_ties_to_the_earlier():
    # queries at 10, 2 and 2 bits all nearest to train row 0 (0 bits; row 1 has 200 bits)
    q, t, _ = hamming_ratio_matches(descriptors(10, 2, 2), descriptors(0, 200), 0.95)
    assert q.tolist() == [1] and t.tolist() == [0]


def test_widths_that_are_no_multiple_of_eight_bytes_count_every_bit():
    # AKAZE's 61-byte descriptors: 488 bits against 0 and 487 bits
    query, train = descriptors(488, width=61), descriptors(0, 487, width=61)
    q, t, ratios = hamming_ratio_matches(query, train, 0.95)
    assert t.tolist() == [1] and ratios.tolist() == [1 / 488]


def test_nearest_matches_keep_every_query_below_the_bound_without_a_ratio_test():
    # train rows at 0 and 7 bits; queries at 6 (nearest 7: 1 bit), 3 (0 and 7: 3 and 4 bits),
    # 40 (33 bits to 7) and 6 again; bound 33 bits: the 40-bit query is out
    q, t, distance = hamming_nearest_matches(descriptors(6, 3, 40, 6), descriptors(0, 7), 33)
    assert q.tolist() == [0, 1, 3] and t.tolist() == [1, 0, 1] and distance.tolist() == [1, 3, 1]
    # equal distances: the first train row; 34 bits lets the 40-bit query in
    assert hamming_nearest_matches(descriptors(2), descriptors(0, 4), 34)[1].tolist() == [0]
    assert hamming_nearest_matches(descriptors(40), descriptors(0, 7), 34)[2].tolist() == [33]


def test_guided_matching_picks_among_the_train_rows_within_the_radius():
    # query (0 bits) at the origin; train rows of 50, 10, 3 and 0 bits at 1, 2.8, 5.8 and
    # 30 px; radius 20 px: the 0-bit row is outside, the 3-bit one is nearest
    # (3 < 0.8 * 10 passes the ratio test)
    train_positions = np.array([[1.0, 0.0], [2.0, 2.0], [5.0, -3.0], [30.0, 0.0]])
    picked = nearest_within_radius(
        np.zeros((1, 2)), descriptors(0), train_positions, descriptors(50, 10, 3, 0), 20.0, 0.8
    )
    assert picked.tolist() == [2]
    assert nearest_within_radius(
        np.zeros((1, 2)), descriptors(0), train_positions, descriptors(50, 10, 9, 0), 20.0, 0.8
    ).tolist() == [-1]  # 9 < 0.8 * 10 fails


def test_the_radius_is_a_circle_open_at_its_edge():
    # (15, 15) is 21.2 px away, outside; (20, 0) lies on the circle, outside; (12, 16) is
    # 20 px away too; (11.9, 16) inside and alone: taken without a test, whatever its distance
    outside = np.array([[15.0, 15.0], [20.0, 0.0], [12.0, 16.0]])
    assert nearest_within_radius(
        np.zeros((1, 2)), descriptors(0), outside, descriptors(0, 0, 0), 20.0, 0.8
    ).tolist() == [-1]
    lone = np.vstack([outside, [[11.9, 16.0]]])
    assert nearest_within_radius(
        np.zeros((1, 2)), descriptors(0), lone, descriptors(0, 0, 0, 200), 20.0, 0.8
    ).tolist() == [3]


def test_equal_nearest_distances_are_ambiguous_and_every_query_picks_on_its_own():
    train_positions = np.array([[9.0, 0.0], [3.0, 0.0], [0.0, 15.0]])
    positions = np.array([[0.0, 0.0], [6.0, 0.0]])
    picked = nearest_within_radius(positions, descriptors(0, 0), train_positions, descriptors(0, 0, 40), 20.0, 1.0)
    assert picked.tolist() == [-1, -1]  # 0 < 1.0 * 0 fails
    # both queries pick row 1 (0 bits against 1): what to do with a row picked twice is the caller's
    picked = nearest_within_radius(positions, descriptors(0, 0), train_positions, descriptors(1, 0, 40), 20.0, 0.8)
    assert picked.tolist() == [1, 1]


def brute_force_nearest(query: np.ndarray, train: np.ndarray, bound: int) -> list[tuple[int, int, int]]:
    """(query, train, distance) for each query's first nearest train row under ``bound``, counted bit by bit."""
    bits = np.unpackbits(query[:, None, :] ^ train[None, :, :], axis=2).sum(axis=2)
    nearest = bits.argmin(axis=1)
    return [(i, int(j), int(bits[i, j])) for i, j in enumerate(nearest) if bits[i, j] < bound]


def test_packed_descriptors_match_as_the_raw_ones_and_as_counted_by_hand_ties_included():
    rng = np.random.default_rng(3)
    for query, train in [
        (rng.integers(0, 256, (300, 32), dtype=np.uint8), rng.integers(0, 256, (250, 32), dtype=np.uint8)),
        (rng.integers(0, 2, (120, 32), dtype=np.uint8), rng.integers(0, 2, (90, 32), dtype=np.uint8)),
        (rng.integers(0, 256, (40, 61), dtype=np.uint8), rng.integers(0, 256, (2, 61), dtype=np.uint8)),
        # BRISK's 64 bytes (two passes of four words) and a width below one pass
        (rng.integers(0, 256, (70, 64), dtype=np.uint8), rng.integers(0, 256, (50, 64), dtype=np.uint8)),
        (rng.integers(0, 256, (70, 16), dtype=np.uint8), rng.integers(0, 256, (50, 16), dtype=np.uint8)),
    ]:
        packed_query, packed_train = PackedDescriptors.of(query), PackedDescriptors.of(train)
        assert len(packed_query) == len(query) and len(packed_train) == len(train)
        nearest = hamming_nearest_matches(packed_query, packed_train, 8 * query.shape[1] // 2)
        assert list(zip(*(part.tolist() for part in nearest))) == brute_force_nearest(
            query, train, 8 * query.shape[1] // 2
        )
        raw = hamming_nearest_matches(query, train, 8 * query.shape[1] // 2)
        assert all(np.array_equal(a, b) for a, b in zip(raw, nearest))
        for ratio in (0.8, 1.0):  # the low-entropy pair has many equal distances: ties decide
            by_ratio = hamming_ratio_matches(packed_query, packed_train, ratio)
            opencv = match_with_ratios(query, train, True, ratio)
            assert all(np.array_equal(a, b) for a, b in zip(by_ratio, opencv))
