"""Ratio-test matching of binary descriptors in compiled code (numba, GIL released).

The same matches as :func:`.features.match_with_ratios` gives for binary descriptors (the
nearest and second-nearest Hamming distances, the ratio test, one match per train
descriptor, the one with the smallest distance, earlier query on ties), in about a third
of the time of OpenCV's ``batchDistance``: the distances are popcounts of 64-bit words.
"""

import numba
import numpy as np

jit = numba.njit(cache=True, nogil=True)
NO_DISTANCE = 1 << 30


@jit
def _popcount(word):
    """Set bits of a 64-bit word (the bit-parallel sum, which LLVM turns into one instruction)."""
    word = word - ((word >> np.uint64(1)) & np.uint64(0x5555555555555555))
    word = (word & np.uint64(0x3333333333333333)) + ((word >> np.uint64(2)) & np.uint64(0x3333333333333333))
    word = (word + (word >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (word * np.uint64(0x0101010101010101)) >> np.uint64(56)


@jit
def _two_nearest(query, train):
    """Per query row: the nearest and second-nearest Hamming distances and the nearest
    train row (the first one on ties)."""
    distances = np.empty((query.shape[0], 2), dtype=np.int64)
    nearest = np.empty(query.shape[0], dtype=np.int64)
    for i in range(query.shape[0]):
        first, second, best = NO_DISTANCE, NO_DISTANCE, 0
        for j in range(train.shape[0]):
            distance = 0
            for k in range(query.shape[1]):
                distance += _popcount(query[i, k] ^ train[j, k])
            if distance < first:
                first, second, best = distance, first, j
            elif distance < second:
                second = distance
        distances[i, 0], distances[i, 1], nearest[i] = first, second, best
    return distances, nearest


@jit
def _ratio_matches(query, train, ratio):
    """The ratio test, then each train row kept for its nearest query."""
    distances, nearest = _two_nearest(query, train)
    claimed = np.full(train.shape[0], -1, dtype=np.int64)
    for i in range(query.shape[0]):
        if distances[i, 0] < ratio * distances[i, 1]:
            owner = claimed[nearest[i]]
            if owner < 0 or distances[i, 0] < distances[owner, 0]:
                claimed[nearest[i]] = i
    query_index = np.array([i for i in range(query.shape[0]) if claimed[nearest[i]] == i], dtype=np.int64)
    train_index = nearest[query_index]
    ratios = distances[query_index, 0] / distances[query_index, 1]
    return query_index, train_index, ratios


def _words(descriptors: np.ndarray) -> np.ndarray:
    """Binary descriptors ``(N, B)`` uint8 as 64-bit words, zero-padded (zero bits add no distance)."""
    padding = -descriptors.shape[1] % 8
    return np.ascontiguousarray(np.pad(descriptors, ((0, 0), (0, padding)))).view(np.uint64)


def hamming_ratio_matches(query: np.ndarray, train: np.ndarray, ratio: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Matches of binary descriptors ``(N, B)`` uint8 that pass the ratio test: query
    indices (ascending), train indices and distance ratios."""
    if len(query) == 0 or len(train) < 2:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    return _ratio_matches(_words(query), _words(train), float(ratio))
