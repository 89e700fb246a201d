"""Compiled ratio-test matching of binary descriptors, whole and guided by image position, against
distances counted by hand."""

import numpy as np

from viewer_slam.frontend.hamming import guided_ratio_matches, hamming_ratio_matches


def descriptors(*bit_counts, width=32):
    """One row per count: that many low bits set, the rest zero."""
    rows = np.zeros((len(bit_counts), width), np.uint8)
    for row, count in zip(rows, bit_counts):
        row[:] = np.packbits(np.arange(width * 8) < count, bitorder="little")
    return rows


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


def test_guided_matching_compares_only_the_candidates_nearest_in_the_image():
    # query (0 bits) at the origin; train rows 50, 10, 3 and 0 bits at Chebyshev distances 1,
    # 2, 5 and 30 px; window 20 px
    positions, train_positions = np.zeros((1, 2)), np.array([[1.0, 0.0], [2.0, 2.0], [5.0, -3.0], [30.0, 0.0]])
    query, train = descriptors(0), descriptors(50, 10, 3, 0)
    two = guided_ratio_matches(positions, query, train_positions, train, 20.0, 2, 0.8, 64)
    assert two[0].tolist() == [0] and two[1].tolist() == [1]        # 10 < 0.8 * 50 among the two nearest
    three = guided_ratio_matches(positions, query, train_positions, train, 20.0, 3, 0.8, 64)
    assert three[1].tolist() == [2]                                   # 3 < 0.8 * 10; the 0-bit row is too far


def test_the_guide_window_is_a_square_open_at_its_edge():
    # (15, 15) is 21 px away but inside the 20 px square; (20, 0) lies on its edge, outside
    positions, train_positions = np.zeros((1, 2)), np.array([[15.0, 15.0], [20.0, 0.0]])
    matched = guided_ratio_matches(positions, descriptors(0), train_positions, descriptors(40, 0), 20.0, 24, 0.8, 64)
    assert matched[1].tolist() == [0]                                 # a lone candidate at 40 <= 64 bits


def test_a_lone_guided_candidate_needs_a_small_distance_and_a_train_row_its_nearest_query():
    train_positions = np.array([[0.0, 0.0], [500.0, 0.0]])
    lone = guided_ratio_matches(np.zeros((1, 2)), descriptors(0), train_positions, descriptors(65, 0), 20.0, 24, 0.8, 64)
    assert len(lone[0]) == 0                                          # 65 > 64 bits
    # three queries all alone with train row 0: 9, 2 and 2 bits; the earlier 2-bit one keeps it
    positions = np.array([[1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    q, t = guided_ratio_matches(positions, descriptors(9, 2, 2), train_positions, descriptors(0, 0), 20.0, 24, 0.8, 64)
    assert q.tolist() == [1] and t.tolist() == [0]
