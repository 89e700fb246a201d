"""Matching of binary descriptors in compiled code (numba, GIL released).

Ratio-test matching gives the same matches as :func:`.features.match_with_ratios` gives for
binary descriptors (the nearest and second-nearest Hamming distances, the ratio test, one
match per train descriptor, the one with the smallest distance, earlier query on ties), in
a third of the time of OpenCV's ``batchDistance``: the distances are popcounts of 64-bit
words, a query's distances to every train descriptor computed word by word on vectors, then
searched.
Nearest-neighbour matching keeps each query's nearest train descriptor under a distance
bound, with no ratio test and no claim on the train side (RGB-D SLAM v2's ORB matching).
Guided matching compares a query only with the train descriptors whose image positions lie
near its own, found on a grid of cells as large as the search window.
"""

from dataclasses import dataclass

import numpy as np

from ..compiled import jit

NO_DISTANCE = 1 << 30
# 64-bit words compared per pass over the train descriptors; descriptors are padded to a multiple.
PASS_WORDS = 4


@jit
def _popcount(word):
    """Set bits of a 64-bit word (the bit-parallel sum, which LLVM turns into one instruction)."""
    word = word - ((word >> np.uint64(1)) & np.uint64(0x5555555555555555))
    word = (word & np.uint64(0x3333333333333333)) + ((word >> np.uint64(2)) & np.uint64(0x3333333333333333))
    word = (word + (word >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (word * np.uint64(0x0101010101010101)) >> np.uint64(56)


@jit
def _two_nearest(query, i, train, rows):
    """The nearest and second-nearest Hamming distances of query row ``i`` among the train
    ``rows``, and the nearest row (the first one on ties)."""
    first, second, nearest = NO_DISTANCE, NO_DISTANCE, -1
    for j in rows:
        distance = 0
        for k in range(query.shape[1]):
            distance += _popcount(query[i, k] ^ train[j, k])
        if distance < first:
            first, second, nearest = distance, first, j
        elif distance < second:
            second = distance
    return first, second, nearest


@jit
def _kept_by_nearest_query(nearest, distance, train_count):
    """The queries (ascending) that matched (``nearest`` >= 0) and are the closest to their
    train row, the earlier query on ties: each train row is matched once."""
    claimed = np.full(train_count, -1, dtype=np.int64)
    for i in range(len(nearest)):
        j = nearest[i]
        if j >= 0 and (claimed[j] < 0 or distance[i] < distance[claimed[j]]):
            claimed[j] = i
    return np.array([i for i in range(len(nearest)) if nearest[i] >= 0 and claimed[nearest[i]] == i], dtype=np.int64)


@jit
def _ratio_matches(query, columns, ratio):
    """The ratio test, then each train row kept for its nearest query. The second-nearest
    distance is the least over every row but the nearest (which equals the nearest's on ties)."""
    distances = np.empty(columns.shape[1], dtype=np.int64)
    first, second = np.empty(query.shape[0], dtype=np.int64), np.empty(query.shape[0], dtype=np.int64)
    nearest = np.full(query.shape[0], -1, dtype=np.int64)
    for i in range(query.shape[0]):
        _distances_to_all(query, i, columns, distances)
        first[i], best = _least(distances)
        second[i] = NO_DISTANCE
        for j in range(distances.shape[0]):
            if j != best and distances[j] < second[i]:
                second[i] = distances[j]
        if first[i] < ratio * second[i]:
            nearest[i] = best
    query_index = _kept_by_nearest_query(nearest, first, columns.shape[1])
    return query_index, nearest[query_index], first[query_index] / second[query_index]


@jit
def _distances_to_all(query, i, columns, distances):
    """The Hamming distances of query row ``i`` to every train descriptor, into ``distances``:
    four words at a time (ORB's 256 bits in one pass) over the word-major ``columns``, a loop
    that runs on vectors (one popcount instruction per lane where the CPU has one)."""
    distances[:] = 0
    for k in range(0, columns.shape[0], PASS_WORDS):
        q0, q1, q2, q3 = query[i, k], query[i, k + 1], query[i, k + 2], query[i, k + 3]
        c0, c1, c2, c3 = columns[k], columns[k + 1], columns[k + 2], columns[k + 3]
        for j in range(columns.shape[1]):
            distances[j] += (
                _popcount(q0 ^ c0[j]) + _popcount(q1 ^ c1[j]) + _popcount(q2 ^ c2[j]) + _popcount(q3 ^ c3[j])
            )


@jit
def _least(distances):
    """The least distance and its first row."""
    least = distances.min()
    row = 0
    while distances[row] != least:
        row += 1
    return least, row


@jit
def _nearest_matches(query, columns, max_distance):
    """Each query's nearest train descriptor (the first on ties) and its distance, for the
    queries whose nearest distance is below ``max_distance``."""
    distances = np.empty(columns.shape[1], dtype=np.int64)
    nearest, distance = np.empty(query.shape[0], dtype=np.int64), np.empty(query.shape[0], dtype=np.int64)
    for i in range(query.shape[0]):
        _distances_to_all(query, i, columns, distances)
        distance[i], nearest[i] = _least(distances)
    query_index = np.flatnonzero(distance < max_distance)
    return query_index, nearest[query_index], distance[query_index]


@jit
def grid_cells(positions, cell):
    """``positions`` bucketed on a grid of ``cell``-sized squares over their bounding box:
    (low x, low y, columns, rows, each cell's start in ``members``, the members)."""
    low_x, low_y = positions[:, 0].min(), positions[:, 1].min()
    columns = int((positions[:, 0].max() - low_x) // cell) + 1
    rows = int((positions[:, 1].max() - low_y) // cell) + 1
    index = np.empty(positions.shape[0], dtype=np.int64)
    starts = np.zeros(columns * rows + 1, dtype=np.int64)
    for j in range(positions.shape[0]):
        index[j] = int((positions[j, 1] - low_y) // cell) * columns + int((positions[j, 0] - low_x) // cell)
        starts[index[j] + 1] += 1
    starts = np.cumsum(starts)
    members = np.empty(starts[-1], dtype=np.int64)
    filled = starts[:-1].copy()
    for j in range(positions.shape[0]):
        members[filled[index[j]]] = j
        filled[index[j]] += 1
    return low_x, low_y, columns, rows, starts, members


@jit
def _near_cells(grid, cell, x, y, found):
    """Fills ``found`` with the grid's members in the 3x3 cells around (x, y), so every
    position within ``cell`` of it; returns how many."""
    low_x, low_y, columns, rows, starts, members = grid
    column, row = int(np.floor((x - low_x) / cell)), int(np.floor((y - low_y) / cell))
    count = 0
    for r in range(max(row - 1, 0), min(row + 2, rows)):
        for c in range(max(column - 1, 0), min(column + 2, columns)):
            for member in members[starts[r * columns + c] : starts[r * columns + c + 1]]:
                found[count] = member
                count += 1
    return count


@jit
def _nearest_within_radius(positions, query, train_positions, train, radius, ratio):
    """Per query, the train row it matches among those positioned closer than ``radius``
    (Euclidean), or -1; see :func:`nearest_within_radius`."""
    chosen = np.full(positions.shape[0], -1, dtype=np.int64)
    if train_positions.shape[0] == 0 or not radius > 0.0:
        return chosen
    grid = grid_cells(train_positions, radius)
    near, within = (
        np.empty(train_positions.shape[0], dtype=np.int64),
        np.empty(train_positions.shape[0], dtype=np.int64),
    )
    for i in range(positions.shape[0]):
        count = 0
        for member in near[: _near_cells(grid, radius, positions[i, 0], positions[i, 1], near)]:
            if (train_positions[member, 0] - positions[i, 0]) ** 2 + (
                train_positions[member, 1] - positions[i, 1]
            ) ** 2 < radius * radius:
                within[count] = member
                count += 1
        if count == 1:
            chosen[i] = within[0]
        elif count > 1:  # equal nearest distances fail the test, so order is moot
            first, second, best = _two_nearest(query, i, train, within[:count])
            if first < ratio * second:
                chosen[i] = best
    return chosen


def _words(descriptors: np.ndarray) -> np.ndarray:
    """Binary descriptors ``(N, B)`` uint8 as 64-bit words, zero-padded to a multiple of
    PASS_WORDS words (zero bits add no distance)."""
    padding = -descriptors.shape[1] % (8 * PASS_WORDS)
    return np.ascontiguousarray(np.pad(descriptors, ((0, 0), (0, padding)))).view(np.uint64)


@dataclass(frozen=True)
class PackedDescriptors:
    """Binary descriptors as 64-bit words, word-major ``columns`` ``(W, N)`` to be searched
    and ``rows`` ``(N, W)`` (a view of them) to be matched: packed once per keypoint set rather
    than once per comparison, since a node is searched by every later frame that it is a
    candidate for. One copy, so a node keeps its descriptors twice, not three times."""

    columns: np.ndarray

    @classmethod
    def of(cls, descriptors: np.ndarray) -> "PackedDescriptors":
        return cls(np.ascontiguousarray(_words(descriptors).T))

    @property
    def rows(self) -> np.ndarray:
        return self.columns.T

    def __len__(self) -> int:
        return self.columns.shape[1]


def packed(descriptors: "np.ndarray | PackedDescriptors") -> PackedDescriptors:
    return descriptors if isinstance(descriptors, PackedDescriptors) else PackedDescriptors.of(descriptors)


def hamming_ratio_matches(
    query: "np.ndarray | PackedDescriptors", train: "np.ndarray | PackedDescriptors", ratio: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Matches of binary descriptors ``(N, B)`` uint8 (or packed) that pass the ratio test: query
    indices (ascending), train indices and distance ratios."""
    if len(query) == 0 or len(train) < 2:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    return _ratio_matches(packed(query).rows, packed(train).columns, float(ratio))


def hamming_nearest_matches(
    query: "np.ndarray | PackedDescriptors", train: "np.ndarray | PackedDescriptors", max_distance: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each query descriptor's nearest train descriptor (``(N, B)`` uint8, or packed), the first
    on ties, when fewer than ``max_distance`` bits apart: query indices (ascending), train indices
    (a train descriptor may be matched by several queries) and Hamming distances."""
    if len(query) == 0 or len(train) == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0, int)
    return _nearest_matches(packed(query).rows, packed(train).columns, int(max_distance))


def nearest_within_radius(
    positions: np.ndarray,
    query: np.ndarray,
    train_positions: np.ndarray,
    train: np.ndarray,
    radius: float,
    ratio: float,
) -> np.ndarray:
    """Per query descriptor ``(N,)``, the index of the train descriptor it matches, or -1,
    among the train descriptors positioned closer than ``radius`` pixels to the query's
    position: the nearest by Hamming distance if it passes the ratio test against the
    second-nearest (ratio at most 1, so equal distances fail it), a lone one without a
    test. This is RTAB-Map's matching with a motion guess (RegistrationVis); what to do when
    several queries choose the same train descriptor is the caller's rule."""
    if len(query) == 0:
        return np.zeros(0, int)
    return _nearest_within_radius(
        np.asarray(positions, np.float64),
        _words(query),
        np.asarray(train_positions, np.float64),
        _words(train),
        float(radius),
        float(ratio),
    )
