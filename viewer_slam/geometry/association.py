"""Timestamp association exactly as the TUM RGB-D tools do it (``associate.py``).

TUM's rule: every pair ``(a, b)`` with ``|a - (b + offset)| < max_difference`` is a
candidate; candidates are taken greedily in order of increasing difference (ties broken by
the smaller ``a``, then the smaller ``b``), each stamp used at most once. TUM's scripts
read a file into a dict keyed by timestamp, so a timestamp that occurs twice is one key
whose row is the last one in the file; the same holds here.

The greedy loop is replaced by rounds of "locally dominant" pairs: a candidate that is the
best remaining one for both of its stamps is taken by the greedy scan too, and taking all
of them at once and discarding their rivals yields the same matching (the candidate order
is total). Each round is a handful of numpy operations, so 20,000 stamps associate in
milliseconds rather than in a Python loop over every candidate.
"""

import numpy as np


def associate(
    first: np.ndarray, second: np.ndarray, offset: float = 0.0, max_difference: float = 0.02
) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i_first, i_second)`` of the matched stamps, ordered by the first stamp.

    ``offset`` is added to the second stamps (``first ≈ second + offset``).
    """
    first = np.asarray(first, dtype=np.float64).reshape(-1)
    second = np.asarray(second, dtype=np.float64).reshape(-1)
    keys_a, rows_a = _last_row_per_stamp(first)
    keys_b, rows_b = _last_row_per_stamp(second)
    a, b, difference = _candidates(keys_a, keys_b, offset, max_difference)

    order = np.lexsort((b, a, difference))
    a, b = a[order], b[order]
    taken_a, taken_b = [], []
    while len(a):
        best_for_a = _first_occurrence_mask(a)
        best_for_b = _first_occurrence_mask(b)
        dominant = best_for_a & best_for_b
        taken_a.append(a[dominant])
        taken_b.append(b[dominant])
        keep = ~np.isin(a, a[dominant]) & ~np.isin(b, b[dominant])
        a, b = a[keep], b[keep]

    matched_a = np.concatenate(taken_a) if taken_a else np.zeros(0, dtype=int)
    matched_b = np.concatenate(taken_b) if taken_b else np.zeros(0, dtype=int)
    by_first = np.argsort(matched_a, kind="stable")
    return rows_a[matched_a[by_first]], rows_b[matched_b[by_first]]


def _last_row_per_stamp(stamps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted distinct stamps and, for each, the index of its last row in ``stamps``."""
    reversed_unique, reversed_index = np.unique(stamps[::-1], return_index=True)
    return reversed_unique, len(stamps) - 1 - reversed_index


def _candidates(
    keys_a: np.ndarray, keys_b: np.ndarray, offset: float, max_difference: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All pairs of sorted distinct stamps closer than ``max_difference``, by index.

    A binary search bounds each ``a``'s window with one stamp of slack on each side; the
    exact TUM expression ``abs(a - (b + offset)) < max_difference`` then decides, so the
    candidates are bit-for-bit those of the reference script.
    """
    shifted_b = keys_b + offset
    low = np.maximum(np.searchsorted(shifted_b, keys_a - max_difference, side="left") - 1, 0)
    high = np.minimum(np.searchsorted(shifted_b, keys_a + max_difference, side="right") + 1, len(keys_b))
    counts = np.maximum(high - low, 0)
    a = np.repeat(np.arange(len(keys_a)), counts)
    starts = np.repeat(low - np.cumsum(counts) + counts, counts)
    b = starts + np.arange(counts.sum())
    difference = np.abs(keys_a[a] - (keys_b[b] + offset))
    close = difference < max_difference
    return a[close], b[close], difference[close]


def _first_occurrence_mask(values: np.ndarray) -> np.ndarray:
    """True where an entry is the first (best ranked) of its value."""
    mask = np.zeros(len(values), dtype=bool)
    mask[np.unique(values, return_index=True)[1]] = True
    return mask
