"""One RGB-D frame as the pipelines see it, and the sequence interface that yields frames."""

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..geometry.camera import Camera
from ..geometry.interpolation import interpolate_poses
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


class TimedFrames:
    """Timing and groundtruth look-ups of a sequence with one colour stamp per frame.

    Subclasses set ``timestamps`` (seconds, increasing) and ``groundtruth``.
    """

    timestamps: np.ndarray
    groundtruth: Trajectory | None

    def __len__(self) -> int:
        return len(self.timestamps)

    @property
    def duration_s(self) -> float:
        return float(self.timestamps[-1] - self.timestamps[0])

    @property
    def frame_period(self) -> float | None:
        """Median time between associated frames (None for a single frame)."""
        return float(np.median(np.diff(self.timestamps))) if len(self.timestamps) > 1 else None

    def groundtruth_at(self, stamps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Groundtruth poses at ``stamps`` and the mask of stamps it covers (see interpolate_poses)."""
        if self.groundtruth is None:
            stamps = np.asarray(stamps, dtype=np.float64).reshape(-1)
            return np.full((len(stamps), 4, 4), np.nan), np.zeros(len(stamps), dtype=bool)
        return interpolate_poses(self.groundtruth, stamps)

    def frames_outside_groundtruth(self) -> np.ndarray:
        """Indices of the frames at which no groundtruth pose can be interpolated."""
        return np.flatnonzero(~self.groundtruth_at(self.timestamps)[1])
