"""Per-frame signals measured while a run goes: what the sensor saw and what the tracker found.

The image signals are cheap on purpose (every ``IMAGE_STEP``-th pixel of each row and
column), so the sink can ride along with any run. The tracker signals are the counts a
pipeline reports in :class:`FrameTracked`; a pipeline that can tell how many matched points
moved inconsistently with the camera reports that share as ``metrics[DYNAMIC_SHARE_METRIC]``.
"""

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from ..dataset.frame import Frame
from ..geometry.interpolation import interpolate_poses
from ..geometry.trajectory import Trajectory
from ..pipelines.events import DYNAMIC_SHARE_METRIC, Event, FrameTracked

IMAGE_STEP = 4
"""Image signals use every 4th pixel of every 4th row: 80x60 samples of a 320x240 frame."""
CORNER_CONTRAST = 20
"""FAST threshold (grey levels) of a distinctive corner: OpenCV's ORB default. A detector
with a relative threshold (GFTT's quality level) finds corners in the sensor noise of a
blank wall; an absolute contrast does not."""
UNIFORM_TOLERANCE = 8
"""Grey levels (of 255) within which a pixel counts as equal to the image's median grey."""


@dataclass(frozen=True)
class ImageSignals:
    """What one RGB-D frame shows, on a downsampled grid.

    ``corners`` counts FAST corners of ``CORNER_CONTRAST`` on the full image;
    ``color_std`` is the standard deviation of the grey image (0..255); ``uniform_share`` the
    share of pixels within ``UNIFORM_TOLERANCE`` of the median grey; ``valid_depth_share``
    the share of pixels with a depth measurement.
    """

    corners: int
    color_std: float
    uniform_share: float
    valid_depth_share: float


_CORNERS = cv2.FastFeatureDetector.create(threshold=CORNER_CONTRAST, nonmaxSuppression=True)


def measure_image(frame: Frame) -> ImageSignals:
    grey = frame.grey[::IMAGE_STEP, ::IMAGE_STEP]
    depth = frame.depth[::IMAGE_STEP, ::IMAGE_STEP]
    return ImageSignals(
        corners=len(_CORNERS.detect(frame.grey)),
        color_std=float(grey.astype(np.float32).std()),
        uniform_share=_uniform_share(grey),
        valid_depth_share=int(np.count_nonzero((depth > 0) & (depth < np.inf))) / depth.size,
    )


def _uniform_share(grey: np.ndarray) -> float:
    """The share of ``grey`` (uint8) within ``UNIFORM_TOLERANCE`` of its median, counted on its
    256-bin histogram rather than by sorting: a grey level's pixels are all in or all out.

    The median of an even count is the mean of the two middle levels, so it may fall halfway;
    the levels within the tolerance are then those from ``ceil(median - tolerance)`` to
    ``floor(median + tolerance)``. The quotient is the one the mean of a boolean mask gives,
    a count divided by the size.
    """
    counts = np.bincount(grey.ravel(), minlength=256)
    cumulative = np.cumsum(counts)
    middle = (grey.size - 1) // 2
    low = int(np.searchsorted(cumulative, middle, side="right"))
    high = low if grey.size % 2 else int(np.searchsorted(cumulative, middle + 1, side="right"))
    first, last = -(-(low + high - 2 * UNIFORM_TOLERANCE) // 2), (low + high + 2 * UNIFORM_TOLERANCE) // 2
    return int(counts[max(first, 0) : last + 1].sum()) / grey.size


class MeasuredImages:
    """The image signals of a sequence's frames, each frame measured once however many runs see it.

    The runs of one record go over the same frames, and what a frame shows does not depend on
    the run that is shown it: measuring it again for each run would only take the same numbers
    twice, on the frame loop. Give one to every run over the same frames of one sequence (a
    frame is known by its index and timestamp).
    """

    def __init__(self) -> None:
        self._measured: dict[tuple[int, float], ImageSignals] = {}

    def __call__(self, frame: Frame) -> ImageSignals:
        key = (frame.index, frame.timestamp)
        measured = self._measured.get(key)
        if measured is None:
            measured = self._measured[key] = measure_image(frame)
        return measured


@dataclass
class FrameSignals:
    """The signals of a run's processed frames, one row per frame in processing order.

    Tracker columns are NaN for frames the pipeline reported nothing for, and for every
    frame of a run that never reports a count (an estimate replayed from a trajectory
    file leaves them all 0); ``tracked`` says which frames had an online pose.
    """

    frame_indices: np.ndarray
    timestamps: np.ndarray
    corners: np.ndarray
    color_std: np.ndarray
    uniform_share: np.ndarray
    valid_depth_share: np.ndarray
    keypoints: np.ndarray
    matches: np.ndarray
    inliers: np.ndarray
    dynamic_share: np.ndarray
    tracked: np.ndarray

    def __len__(self) -> int:
        return len(self.frame_indices)

    def position(self, frame_index: int) -> int:
        """Row of ``frame_index``, or of the first processed frame after it."""
        return int(np.searchsorted(self.frame_indices, frame_index))


class SignalRecorder:
    """A run's signal sink: give it each frame (``frame``) and each event (call it).

    ``measure`` gives a frame's image signals: :func:`measure_image`, or the
    :class:`MeasuredImages` that the runs over the same frames share.
    """

    def __init__(self, measure: Callable[[Frame], ImageSignals] = measure_image):
        self._measure = measure
        self._images: dict[int, tuple[float, ImageSignals]] = {}
        self._tracked: dict[int, FrameTracked] = {}

    def frame(self, frame: Frame) -> None:
        self._images[frame.index] = (frame.timestamp, self._measure(frame))

    def __call__(self, event: Event) -> None:
        if isinstance(event, FrameTracked):
            self._tracked[event.frame_index] = event

    def signals(self) -> FrameSignals:
        indices = sorted(self._images)
        images = [self._images[index][1] for index in indices]
        tracked = [self._tracked.get(index) for index in indices]

        def image(name: str) -> np.ndarray:
            return np.array([getattr(signals, name) for signals in images], dtype=np.float64)

        counted = any(event.features or event.matches or event.inliers for event in self._tracked.values())

        def tracker(value) -> np.ndarray:
            return np.array(
                [np.nan if event is None or not counted else value(event) for event in tracked], dtype=np.float64
            )

        return FrameSignals(
            frame_indices=np.array(indices, dtype=np.int64),
            timestamps=np.array([self._images[index][0] for index in indices], dtype=np.float64),
            corners=image("corners"),
            color_std=image("color_std"),
            uniform_share=image("uniform_share"),
            valid_depth_share=image("valid_depth_share"),
            keypoints=tracker(lambda event: event.features),
            matches=tracker(lambda event: event.matches),
            inliers=tracker(lambda event: event.inliers),
            dynamic_share=np.array(
                [np.nan if event is None else event.metrics.get(DYNAMIC_SHARE_METRIC, np.nan) for event in tracked],
                dtype=np.float64,
            ),
            tracked=np.array([event is not None and event.pose is not None for event in tracked], dtype=bool),
        )


def groundtruth_motion(groundtruth: Trajectory | None, timestamps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Groundtruth speed (m/s) and rotation rate (rad/s) into each frame from the one before.

    NaN for the first frame and wherever the groundtruth does not cover both frames.
    """
    timestamps = np.asarray(timestamps, dtype=np.float64)
    speed = np.full(len(timestamps), np.nan)
    rotation_rate = np.full(len(timestamps), np.nan)
    if groundtruth is None or len(timestamps) < 2:
        return speed, rotation_rate
    poses, covered = interpolate_poses(groundtruth, timestamps)
    both = covered[1:] & covered[:-1]
    elapsed = np.diff(timestamps)[both]
    before, after = poses[:-1][both], poses[1:][both]
    moved = np.linalg.norm(after[:, :3, 3] - before[:, :3, 3], axis=1)
    turned = (
        Rotation.from_matrix(np.swapaxes(before[:, :3, :3], 1, 2) @ after[:, :3, :3]).magnitude()
        if len(before)
        else np.zeros(0)
    )
    rows = np.flatnonzero(both) + 1
    speed[rows] = moved / elapsed
    rotation_rate[rows] = turned / elapsed
    return speed, rotation_rate
