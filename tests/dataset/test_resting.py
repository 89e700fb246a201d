from pathlib import Path

import numpy as np

from viewer_slam.dataset.frame import Frame
from viewer_slam.dataset.resting import RestingStart


class Numbered:
    name, path, camera, groundtruth = "numbered", Path("numbered"), None, None
    timestamps = 10.0 + np.arange(5)

    def __len__(self):
        return 5

    def frames(self, max_frames=None, stride=1):
        for i in range(5):
            yield Frame(i, float(self.timestamps[i]), np.full((2, 2, 3), i, np.uint8), np.zeros((2, 2), np.float32))


def test_rest_precedes_the_sequence_with_copies_of_its_first_frame():
    frames = list(RestingStart(Numbered(), 3).frames())
    assert [f.index for f in frames] == list(range(8))
    np.testing.assert_allclose(
        [f.timestamp for f in frames], [10 - 3 / 30, 10 - 2 / 30, 10 - 1 / 30, 10, 11, 12, 13, 14]
    )
    assert all(f.rgb[0, 0, 0] == 0 for f in frames[:4])
    assert len(RestingStart(Numbered(), 3)) == 8


def test_stride_and_limit():
    frames = list(RestingStart(Numbered(), 3).frames(max_frames=3, stride=2))
    assert [f.index for f in frames] == [0, 2, 4]
