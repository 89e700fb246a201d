"""What RTAB-Map's bundle adjustments work on.

The odometry's (OdomF2M/BundleAdjustment), as in ``OdometryF2M::computeTransform``: every
key frame records where it saw each local map point it registered on or added (the word
references); a key frame stays in the bundle while some map point still refers to it. Each
registration is then adjusted against the key frames that saw its inlier points, a point's
references thinned to about OdomF2M/BundleAdjustmentMaxFrames of them (every k-th, and
always the newest).

A registration's between two locations (Vis/BundleAdjustment), as in
``RegistrationVis::computeTransformationImpl``: the older location fixed at the origin, the
newer free, the inliers' 3D points (the older location's) free, each seen in both with its
depth where it has one, and the registration itself as the link between the two.
"""

from collections.abc import Container
from itertools import chain
from operator import itemgetter

import numpy as np

from ...backend.local_bundle import FREE_FRAME, Observations

Reference = tuple[int, float, float, float]  # key frame, undistorted u, v, depth (NaN: none)
key_frame_of = itemgetter(0)  # a reference's key frame


class KeyFrames:
    """Poses (``T_odom_camera``) of the key frames some map point refers to; ``last`` is
    the newest, the one a registration is linked to."""

    def __init__(self):
        self.poses: dict[int, np.ndarray] = {}
        self.last: int | None = None

    def add(self, frame: int, pose: np.ndarray) -> None:
        self.poses[frame] = pose
        self.last = frame

    def keep_referenced(self, referenced: Container[int]) -> None:
        """Forget the key frames not in ``referenced``, those no point refers to any more (the
        newest stays)."""
        self.poses = {frame: pose for frame, pose in self.poses.items() if frame in referenced or frame == self.last}


def sampled(references: list[Reference], max_frames: int) -> list[Reference]:
    """Every k-th reference, k = len // max_frames (1 when that is 0 or max_frames is 0),
    plus the newest."""
    step = max(1, len(references) // max_frames) if max_frames > 0 else 1
    chosen = references[::step]
    if len(references) > 1 and chosen[-1] is not references[-1]:
        chosen.append(references[-1])
    return chosen


def bundle_observations(
    references: list[list[Reference]], pixels: np.ndarray, depth: np.ndarray, max_frames: int
) -> Observations:
    """The observations of points ``0..n-1``: their sampled key-frame references, then the
    adjusted frame's own at ``pixels`` (n, 2) with ``depth`` (n,)."""
    # A point seen by fewer than twice max_frames key frames keeps every reference (k = 1).
    chosen = [point if len(point) < 2 * max_frames else sampled(point, max_frames) for point in references]
    count = len(pixels)
    # the references' numbers in one flat run: no Python tuple per reference for NumPy to unpack
    stored = np.fromiter(chain.from_iterable(chain.from_iterable(chosen)), dtype=np.float64).reshape(-1, 4)
    return Observations(
        point=np.concatenate([np.repeat(np.arange(len(chosen)), list(map(len, chosen))), np.arange(count)]),
        frame=np.concatenate([stored[:, 0].astype(int), np.full(count, FREE_FRAME)]),
        pixels=np.concatenate([stored[:, 1:3], pixels]),
        depth=np.concatenate([stored[:, 3], depth]),
    )


OLDER = 0  # the older location's frame id in a two-view adjustment


def two_view_observations(
    older_pixels: np.ndarray, older_depth: np.ndarray, newer_pixels: np.ndarray, newer_depth: np.ndarray
) -> Observations:
    """Points ``0..n-1`` seen by the older location (frame OLDER) at ``older_pixels`` with
    ``older_depth`` and by the adjusted newer one at ``newer_pixels`` with ``newer_depth``
    (NaN: a plain projection)."""
    count = len(older_pixels)
    return Observations(
        point=np.concatenate([np.arange(count), np.arange(count)]),
        frame=np.concatenate([np.full(count, OLDER), np.full(count, FREE_FRAME)]),
        pixels=np.concatenate([older_pixels, newer_pixels]).astype(np.float64),
        depth=np.concatenate([older_depth, newer_depth]).astype(np.float64),
    )
