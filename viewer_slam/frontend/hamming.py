"""Ratio-test matching of binary descriptors in compiled code (numba, GIL released).

The same matches as :func:`.features.match_with_ratios` gives for binary descriptors (the
nearest and second-nearest Hamming distances, the ratio test, one match per train
descriptor, the one with the smallest distance, earlier query on ties), in about a third
of the time of OpenCV's ``batchDistance``: the distances are popcounts of 64-bit words.
Guided matching does the same among the train descriptors whose image positions lie near
each query's, found on a grid of window-sized cells.
"""

import numpy as np

from ..compiled import jit

NO_DISTANCE = 1 << 30


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
def _ratio_matches(query, train, ratio):
    """The ratio test, then each train row kept for its nearest query."""
    rows = np.arange(train.shape[0])
    first, second = np.empty(query.shape[0], dtype=np.int64), np.empty(query.shape[0], dtype=np.int64)
    nearest = np.full(query.shape[0], -1, dtype=np.int64)
    for i in range(query.shape[0]):
        first[i], second[i], best = _two_nearest(query, i, train, rows)
        if first[i] < ratio * second[i]:
            nearest[i] = best
    query_index = _kept_by_nearest_query(nearest, first, train.shape[0])
    return query_index, nearest[query_index], first[query_index] / second[query_index]


@jit
def _window_candidates(positions, train_positions, window, count):
    """Per query position, the ``count`` train positions nearest to it (Chebyshev distance,
    lower index on ties) closer than ``window``, nearest first; -1 fills the rest. The train
    positions are bucketed on a grid of ``window``-sized cells over the queries' bounding
    box, so only the 3x3 cells around a query are searched."""
    candidates = np.full((positions.shape[0], count), -1, dtype=np.int64)
    if positions.shape[0] == 0 or not window > 0.0:
        return candidates
    low_x, low_y = positions[:, 0].min() - window, positions[:, 1].min() - window
    columns = int((positions[:, 0].max() + window - low_x) // window) + 1
    rows = int((positions[:, 1].max() + window - low_y) // window) + 1
    cell = np.full(train_positions.shape[0], -1, dtype=np.int64)
    starts = np.zeros(columns * rows + 1, dtype=np.int64)
    for j in range(train_positions.shape[0]):
        column = np.floor((train_positions[j, 0] - low_x) / window)
        row = np.floor((train_positions[j, 1] - low_y) / window)
        if 0 <= column < columns and 0 <= row < rows:
            cell[j] = int(row) * columns + int(column)
            starts[cell[j] + 1] += 1
    starts = np.cumsum(starts)
    members = np.empty(starts[-1], dtype=np.int64)
    filled = starts[:-1].copy()
    for j in range(train_positions.shape[0]):       # in index order, so each cell lists its members ascending
        if cell[j] >= 0:
            members[filled[cell[j]]] = j
            filled[cell[j]] += 1
    nearest = np.empty(count)                        # distances of the candidates kept so far, ascending
    for i in range(positions.shape[0]):
        column = int(np.floor((positions[i, 0] - low_x) / window))
        row = int(np.floor((positions[i, 1] - low_y) / window))
        kept = 0
        for r in range(max(row - 1, 0), min(row + 2, rows)):
            for c in range(max(column - 1, 0), min(column + 2, columns)):
                for member in members[starts[r * columns + c]:starts[r * columns + c + 1]]:
                    d = max(abs(train_positions[member, 0] - positions[i, 0]),
                            abs(train_positions[member, 1] - positions[i, 1]))
                    if not d < window:
                        continue
                    slot = kept                      # insertion by (distance, index) into the sorted list
                    while slot > 0 and (nearest[slot - 1] > d or nearest[slot - 1] == d
                                        and candidates[i, slot - 1] > member):
                        slot -= 1
                    if slot == count:
                        continue
                    for moved in range(min(kept, count - 1), slot, -1):
                        nearest[moved], candidates[i, moved] = nearest[moved - 1], candidates[i, moved - 1]
                    nearest[slot], candidates[i, slot] = d, member
                    kept = min(kept + 1, count)
    return candidates


@jit
def _guided_ratio_matches(query, train, candidates, ratio, lone_max_distance):
    """Per query, the nearest and second-nearest of its candidates by Hamming distance (the
    earlier candidate on ties); the ratio test, or for a lone candidate a distance of at most
    ``lone_max_distance``; then each train row kept for its nearest query."""
    first = np.full(query.shape[0], NO_DISTANCE, dtype=np.int64)
    nearest = np.full(query.shape[0], -1, dtype=np.int64)
    for i in range(query.shape[0]):
        count = 0
        while count < candidates.shape[1] and candidates[i, count] >= 0:
            count += 1
        distance, second, best = _two_nearest(query, i, train, candidates[i, :count])
        if count == 1 and distance <= lone_max_distance or count > 1 and distance < ratio * second:
            first[i], nearest[i] = distance, best
    query_index = _kept_by_nearest_query(nearest, first, train.shape[0])
    return query_index, nearest[query_index]


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


def guided_ratio_matches(positions: np.ndarray, query: np.ndarray, train_positions: np.ndarray, train: np.ndarray,
                         window: float, candidates: int, ratio: float,
                         lone_max_distance: int) -> tuple[np.ndarray, np.ndarray]:
    """Matches (query index ascending, train index) of binary descriptors among each query's
    ``candidates`` train descriptors positioned nearest to it within ``window`` pixels
    (Chebyshev distance): the ratio test among them, a lone candidate kept within
    ``lone_max_distance`` bits, and each train descriptor kept for its nearest query."""
    if len(query) == 0 or len(train) < 2:
        return np.zeros(0, int), np.zeros(0, int)
    nearby = _window_candidates(np.asarray(positions, np.float64), np.asarray(train_positions, np.float64),
                                float(window), min(candidates, len(train)))
    return _guided_ratio_matches(_words(query), _words(train), nearby, float(ratio), int(lone_max_distance))
