"""Which projected map points have a corner within the guess window, compiled (numba).

RegistrationVis keeps the map points it projected within Vis/CorGuessWinSize pixels of a
corner (``projectedIDs``). Asked of every projection of the local map on every frame, a
k-d tree's ball query (``cKDTree(corners).query_ball_point(points, radius) > 0``) spends
more on building the tree and on the calls than on the distances; a grid of cells as large
as the window, searched in compiled code, answers the same: a point has a neighbour when a
corner's squared distance to it, the difference of x squared plus that of y squared in
float64, is at most the radius squared, as the tree measures it.
"""

import numpy as np

from ...compiled import jit
from ...frontend.hamming import grid_cells

# The cells searched span the window widened by this share of it, so that a corner whose
# rounded distance is the radius is never in a cell left out.
REACH_MARGIN = 1e-9
MAX_CELLS_ACROSS = 256  # cells grow beyond the radius where it is this small a share of the extent


@jit
def _span(low, value, reach, cell, count):
    """The first and last of ``count`` ``cell``-sized cells from ``low`` that ``value`` ± ``reach`` touches
    (the last before the first when none)."""
    first = min(max(np.floor((value - reach - low) / cell), 0.0), float(count))
    last = max(min(np.floor((value + reach - low) / cell), count - 1.0), -1.0)
    return int(first), int(last)


@jit
def _has_neighbour(points, others, radius):
    found = np.zeros(points.shape[0], dtype=np.bool_)
    if others.shape[0] == 0 or not radius > 0.0:
        return found
    extent = max(others[:, 0].max() - others[:, 0].min(), others[:, 1].max() - others[:, 1].min())
    size = max(radius, extent / MAX_CELLS_ACROSS)
    low_x, low_y, columns, rows, starts, members = grid_cells(others, size)
    limit, reach = radius * radius, radius * (1.0 + REACH_MARGIN)
    for i in range(points.shape[0]):
        x, y = points[i, 0], points[i, 1]
        first_column, last_column = _span(low_x, x, reach, size, columns)
        first_row, last_row = _span(low_y, y, reach, size, rows)
        for row in range(first_row, last_row + 1):
            for column in range(first_column, last_column + 1):
                cell = row * columns + column
                for member in members[starts[cell] : starts[cell + 1]]:
                    dx, dy = others[member, 0] - x, others[member, 1] - y
                    if dx * dx + dy * dy <= limit:
                        found[i] = True
                        break
                if found[i]:
                    break
            if found[i]:
                break
    return found


def has_neighbour_within(points: np.ndarray, others: np.ndarray, radius: float) -> np.ndarray:
    """Per point ``(N, 2)``, whether one of ``others`` ``(M, 2)`` lies within ``radius``
    (Euclidean, the bound included), for finite positions and a positive radius."""
    if len(points) == 0:
        return np.zeros(0, bool)
    return _has_neighbour(np.asarray(points, np.float64), np.asarray(others, np.float64), float(radius))
