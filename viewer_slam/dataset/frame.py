"""One RGB-D frame as the pipelines see it, and the sequence interface that yields frames."""

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property
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

    @cached_property
    def grey(self) -> np.ndarray:
        """``rgb`` in grey levels, ``(H, W)`` uint8 (OpenCV's RGB to grey), converted once for
        all who read it: the image signals and the feature extraction of the same frame."""
        import cv2  # OpenCV loads only when pixels are read, not for listings and groundtruth

        return cv2.cvtColor(self.rgb, cv2.COLOR_RGB2GRAY)


def select_frames(length: int, max_frames: int | None = None, stride: int = 1) -> range:
    """The indices of the frames a run processes out of ``length``: every ``stride``-th, then at
    most the first ``max_frames`` of those (``--stride`` and ``--max-frames``).

    Sequences yield these frames, and whoever needs to know them before the frames are read
    (a replayed estimate, a progress bar) asks here, so the rule is written once.
    """
    if stride < 1:
        raise ValueError(f"stride must be at least 1, got {stride}")
    indices = range(0, length, stride)
    return indices if max_frames is None else indices[:max_frames]


def frames_read(max_frames: int | None = None, stride: int = 1) -> int | None:
    """How many leading frames of a sequence :func:`select_frames` reaches into (None: all of them),
    so a synthetic scenario need be rendered that far only."""
    return None if max_frames is None else (max_frames - 1) * stride + 1


@contextmanager
def closing_frames(frames: Iterator[Frame]) -> Iterator[Iterator[Frame]]:
    """``frames`` closed when the block ends, by an explicit call: a generator left to the garbage
    collector is closed where an exception it raises (a third stop signal landing while its
    reader thread is joined) is only printed, never raised."""
    try:
        yield frames
    finally:
        close = getattr(frames, "close", None)
        if close is not None:
            close()


class Sequence(Protocol):
    """What pipelines and tools need of a sequence (a TUM folder and a ROS bag implement it).

    ``timestamps`` holds every frame's colour stamp (seconds, increasing). ``frames`` yields
    lazily, one frame in memory at a time, the frames :func:`select_frames` names.
    """

    name: str
    path: Path
    camera: Camera
    groundtruth: Trajectory | None
    timestamps: np.ndarray

    def __len__(self) -> int: ...

    @property
    def duration_s(self) -> float: ...

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
