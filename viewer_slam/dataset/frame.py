"""One RGB-D frame as the pipelines see it, and the sequence interface that yields frames."""

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..geometry.camera import Camera
from ..geometry.trajectory import Trajectory


@dataclass(frozen=True)
class Frame:
    """A colour image registered to a depth image.

    ``rgb`` is ``(H, W, 3)`` uint8 in RGB order; ``depth`` is ``(H, W)`` float32 metres with
    0 where the sensor measured nothing. ``index`` is the frame's position in the sequence's
    list of associated colour/depth pairs (strides skip indices, they do not renumber);
    ``timestamp`` is the colour image's time in seconds.
    """

    index: int
    timestamp: float
    rgb: np.ndarray
    depth: np.ndarray


class Sequence(Protocol):
    """What pipelines and tools need of a sequence (a TUM folder implements it).

    ``frames`` yields lazily, one frame in memory at a time; ``max_frames`` counts yielded
    frames, ``stride`` keeps every k-th associated pair.
    """

    name: str
    path: Path
    camera: Camera
    groundtruth: Trajectory | None

    def __len__(self) -> int: ...

    def frames(self, max_frames: int | None = None, stride: int = 1) -> Iterator[Frame]: ...
