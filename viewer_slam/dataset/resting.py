"""A sequence that first rests on its opening view, as hand-held recordings often begin."""

import dataclasses
import itertools
from collections.abc import Iterator

import numpy as np

from .frame import Frame, Sequence, select_frames

REST_RATE_HZ = 30.0


class RestingStart:
    """``sequence`` preceded by ``rest`` copies of its first frame, 1/30 s apart.

    RTAB-Map weighs a place by how long the camera stays on it (rehearsal); a run that
    starts at rest gives its first place the weight that keeps it in Working Memory when
    memory management is on. Frames are re-indexed from 0; the copies' stamps precede the
    first frame's, so the groundtruth still covers the moving part.
    """

    def __init__(self, sequence: Sequence, rest: int):
        self.sequence, self.rest = sequence, rest
        self.name, self.path = f"{sequence.name}-rest{rest}", sequence.path
        self.camera, self.groundtruth = sequence.camera, sequence.groundtruth
        first = float(sequence.timestamps[0])
        self.timestamps = np.concatenate([first - (rest - np.arange(rest)) / REST_RATE_HZ, sequence.timestamps])

    def __len__(self) -> int:
        return len(self.timestamps)

    @property
    def duration_s(self) -> float:
        return float(self.timestamps[-1] - self.timestamps[0])

    def frames(self, max_frames: int | None = None, stride: int = 1) -> Iterator[Frame]:
        selected = select_frames(len(self), max_frames, stride)
        inner = self.sequence.frames()
        first = next(inner)
        resting = (dataclasses.replace(first, index=i, timestamp=float(self.timestamps[i])) for i in range(self.rest))
        moving = (
            dataclasses.replace(frame, index=frame.index + self.rest) for frame in itertools.chain([first], inner)
        )
        kept = (frame for frame in itertools.chain(resting, moving) if frame.index in selected)
        return itertools.islice(kept, len(selected))
