"""Long streams from short sequences, for the measurements that need thousands of frames."""

from collections.abc import Iterator

import viewer_slam.code_paths  # noqa: F401  (before NumPy loads: holds it to one code path)

import numpy as np

from viewer_slam.dataset.frame import Frame, TimedFrames, select_frames
from viewer_slam.dataset.sources import RgbdSequence
from viewer_slam.geometry.trajectory import Trajectory


class PingPong(TimedFrames):
    """``length`` frames of ``sequence`` played forwards, backwards, forwards... at its frame rate.

    Rendering or reading thousands of frames would take longer than the measurement itself;
    played back and forth, a short sequence keeps the camera moving and time running on. The
    stamps start at ``start`` (the sequence's first stamp by default) and the groundtruth, where
    the sequence has one, follows the frames.
    """

    def __init__(self, sequence: RgbdSequence, length: int, start: float | None = None):
        period = 2 * len(sequence) - 2
        step = np.arange(length)
        phase = step % period
        self._sequence = sequence
        self._source = np.where(phase < len(sequence), phase, period - phase)
        first = sequence.timestamps[0] if start is None else start
        self.timestamps = first + step * np.median(np.diff(sequence.timestamps))
        self.groundtruth = None
        if sequence.groundtruth is not None:
            self.groundtruth = Trajectory(
                self.timestamps, sequence.groundtruth_at(sequence.timestamps[self._source])[0]
            )
        self.name, self.path, self.camera = f"{sequence.name}-pingpong-{length}", sequence.path, sequence.camera

    def frames(self, max_frames: int | None = None, stride: int = 1) -> Iterator[Frame]:
        for index in select_frames(len(self), max_frames, stride):
            source = self._sequence.frame(int(self._source[index]))
            yield Frame(index, float(self.timestamps[index]), source.rgb, source.depth)
