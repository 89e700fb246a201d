"""A sequence that first rests on its opening view, as hand-held recordings often begin."""

import dataclasses
import itertools
from collections.abc import Iterator

from .frame import Frame, Sequence


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

    def __len__(self) -> int:
        return len(self.sequence) + self.rest

    def frames(self, max_frames: int | None = None, stride: int = 1) -> Iterator[Frame]:
        inner = self.sequence.frames()
        first = next(inner)
        resting = (dataclasses.replace(first, index=i, timestamp=first.timestamp - (self.rest - i) / 30.0)
                   for i in range(self.rest))
        moving = (dataclasses.replace(frame, index=frame.index + self.rest) for frame in itertools.chain([first], inner))
        strided = (frame for frame in itertools.chain(resting, moving) if frame.index % stride == 0)
        return itertools.islice(strided, max_frames)
