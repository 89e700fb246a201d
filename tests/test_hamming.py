"""Compiled ratio-test matching of binary descriptors against distances counted by hand."""

import numpy as np

from viewer_slam.frontend.hamming import hamming_ratio_matches


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
