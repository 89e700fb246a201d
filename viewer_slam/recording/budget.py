"""How often a recording may re-log what keeps growing during a run."""


class SnapshotBudget:
    """When to re-log something that grows as the run goes (the map, keyframes, loop closures).

    Re-logging the whole of it at every change costs space quadratic in the run's length.
    Logging it only once the frames since the last snapshot have earned its size, at
    ``bytes_per_frame`` each, keeps the total linear, while small snapshots early in the
    run still update often.
    """

    def __init__(self, bytes_per_frame: int):
        self.bytes_per_frame = bytes_per_frame
        self.dirty = False
        self._last_frame: int | None = None

    def due(self, frame_index: int, size_bytes: int) -> bool:
        if not self.dirty:
            return False
        return self._last_frame is None or (frame_index - self._last_frame) * self.bytes_per_frame >= size_bytes

    def logged(self, frame_index: int) -> None:
        self.dirty = False
        self._last_frame = frame_index
