"""benchmarks.streams: a short sequence played back and forth as one long stream."""

import numpy as np

from benchmarks.streams import PingPong
from viewer_slam.dataset.sources import open_source


def test_forwards_backwards_forwards_with_time_running_on(tiny_scene):
    sequence = open_source(tiny_scene)  # 10 frames
    stream = PingPong(sequence, 25)
    frames = list(stream.frames())
    assert len(stream) == len(frames) == 25
    assert [frame.index for frame in frames] == list(range(25))
    source = [
        int(np.flatnonzero([np.array_equal(frame.rgb, sequence.frame(i).rgb) for i in range(10)])[0])
        for frame in frames
    ]
    assert source == [*range(10), *range(8, 0, -1), *range(0, 7)]
    period = np.median(np.diff(sequence.timestamps))
    assert np.allclose(np.diff(stream.timestamps), period) and stream.timestamps[0] == sequence.timestamps[0]
    assert np.allclose(stream.groundtruth.poses[12], sequence.groundtruth_at(sequence.timestamps[6:7])[0][0])
    assert PingPong(sequence, 5, start=0.0).timestamps[0] == 0.0
