"""How often a recording may re-log what keeps growing during a run."""

import math


class SnapshotBudget:
    """When to re-log something that grows as the run goes (the map, keyframes, edges).

    Re-logging the whole of it at every change costs space quadratic in the run's length.
    Logging it only once the frames since the last snapshot have earned its size, at
    ``bytes_per_frame`` each, keeps the total linear, while small snapshots early in the
    run still update often. With ``min_share`` below 1 a snapshot is due once the frames
    have earned that share of its size, and is then thinned to what they earned
    (:meth:`share`): more frequent, sparser pictures for the same bytes.
    """

    def __init__(self, bytes_per_frame: int, min_share: float = 1.0):
        self.bytes_per_frame = bytes_per_frame
        self.min_share = min_share
        self.dirty = False
        self._last_frame: int | None = None

    def earned(self, frame_index: int) -> float:
        """Bytes the frames since the last snapshot have earned (unbounded before the first)."""
        if self._last_frame is None:
            return math.inf
        return (frame_index - self._last_frame) * self.bytes_per_frame

    def due(self, frame_index: int, size_bytes: int) -> bool:
        return self.dirty and self.earned(frame_index) >= self.min_share * size_bytes

    def share(self, frame_index: int, size_bytes: int) -> float:
        """The share of a ``size_bytes`` snapshot that the frames have paid for (at most 1)."""
        return 1.0 if size_bytes <= 0 else min(1.0, self.earned(frame_index) / size_bytes)

    def logged(self, frame_index: int) -> None:
        self.dirty = False
        self._last_frame = frame_index
