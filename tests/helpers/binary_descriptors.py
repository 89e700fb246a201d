"""Binary descriptors whose Hamming distances can be counted by hand."""

import numpy as np


def descriptors(*bit_counts: int, width: int = 32) -> np.ndarray:
    """One row per count: that many low bits set, the rest zero, so two rows differ in the
    difference of their counts."""
    rows = np.zeros((len(bit_counts), width), np.uint8)
    for row, count in zip(rows, bit_counts):
        row[:] = np.packbits(np.arange(width * 8) < count, bitorder="little")
    return rows
