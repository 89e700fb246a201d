"""Milliseconds per stage of one frame, summed per stage name, for the FrameTracked timings."""

import time
from collections.abc import Callable, Iterable
from typing import Any


class Stopwatch:
    """Times stages either as ``with watch("stage"):`` or as ``watch("stage", function, *args)``."""

    def __init__(self, stages: Iterable[str] = ()):
        self.ms: dict[str, float] = dict.fromkeys(stages, 0.0)
        self._open: list[tuple[str, float]] = []

    def __call__(self, stage: str, function: Callable | None = None, *args) -> Any:
        if function is None:
            self._open.append((stage, 0.0))
            return self
        start = time.perf_counter()
        try:
            return function(*args)
        finally:
            self.add(stage, (time.perf_counter() - start) * 1e3)

    def __enter__(self) -> None:
        stage, _ = self._open.pop()
        self._open.append((stage, time.perf_counter()))

    def __exit__(self, *_) -> None:
        stage, start = self._open.pop()
        self.add(stage, (time.perf_counter() - start) * 1e3)

    def add(self, stage: str, ms: float) -> None:
        self.ms[stage] = self.ms.get(stage, 0.0) + ms
