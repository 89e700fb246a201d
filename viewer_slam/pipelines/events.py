"""The events a pipeline emits while it runs.

Pipelines know nothing of Rerun or files: they return these plain objects from
``process``/``finish`` and sinks (trajectory writer, recorder, statistics) consume them.
Poses are 4x4 ``T_map_camera`` in the pipeline's own map frame; points are in that frame.
"""

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from .edges import EdgeKind


class TrackingStatus(str, Enum):
    INITIALISING = "initialising"
    OK = "ok"
    LOST = "lost"
    RELOCALISED = "relocalised"


DYNAMIC_SHARE_METRIC = "dynamic_share"
"""The ``FrameTracked.metrics`` key for the share (0..1) of matched points whose residual
under the frame's estimated camera motion exceeds the pipeline's inlier threshold: what the
loss diagnosis reads for its "dynamic scene" cause."""


@dataclass
class FrameTracked:
    """One per processed frame. ``pose`` is the online estimate (None when lost).

    ``timings_ms`` maps stage names (features, matching, ransac, optimisation, ...) to
    milliseconds spent on this frame; ``metrics`` holds extra per-frame series a pipeline
    wants plotted (e.g. memory sizes).
    """

    frame_index: int
    timestamp: float
    pose: np.ndarray | None
    status: TrackingStatus
    features: int = 0
    matches: int = 0
    inliers: int = 0
    keyframe_id: int | None = None
    timings_ms: dict[str, float] = field(default_factory=dict)
    metrics: dict[str, float] = field(default_factory=dict)


@dataclass
class KeyframeAdded:
    """A new graph node. ``image``/``depth`` are optional (thumbnails, depth at keyframes)."""

    keyframe_id: int
    frame_index: int
    timestamp: float
    pose: np.ndarray
    image: np.ndarray | None = None
    depth: np.ndarray | None = None


@dataclass
class FeatureMatches:
    """Correspondences used to track ``frame_index``.

    ``points_current`` are pixels in the current image; ``points_reference`` are the
    matched pixels in the reference image (a keyframe) or, for frame-to-map tracking,
    the matched map points projected into the current image with the estimated pose.
    """

    frame_index: int
    reference: str
    points_current: np.ndarray
    points_reference: np.ndarray
    inlier_mask: np.ndarray


@dataclass
class GraphEdge:
    """An edge hypothesis between two keyframes, accepted or rejected (and why).

    ``kind`` says what the edge is, by the one rule of :mod:`.edges` (only ``loop`` edges
    are loop closures); ``detection`` says how the pipeline found it (``appearance``,
    ``proximity``, ``predecessor``, ``neighbour``, ``sampled``, ...).
    """

    frame_index: int
    from_keyframe: int
    to_keyframe: int
    accepted: bool
    reason: str
    kind: EdgeKind
    score: float = 0.0
    inliers: int = 0
    detection: str = "appearance"


@dataclass
class GraphOptimized:
    """Keyframe poses after an optimisation and the graph error before and after it."""

    frame_index: int
    keyframe_ids: np.ndarray
    poses: np.ndarray
    error_before: float
    error_after: float


class MapUpdated:
    """Map points ``(N, 3)`` and colours ``(N, 3)`` uint8, added or replacing the map.

    A whole map rebuilt after each optimisation is costly (every node's cloud moved to its
    pose) and serves only a sink that shows it: :meth:`deferred` makes the event with the
    points computed when first read, from inputs fixed when it was made, so a run without a
    recorder never computes them and a recorder only those it shows.
    """

    def __init__(self, frame_index: int, points: np.ndarray, colors: np.ndarray, replace: bool = False):
        self.frame_index, self.replace = frame_index, replace
        self.point_count = len(points)
        self._cloud: tuple[np.ndarray, np.ndarray] | None = (points, colors)
        self._build: Callable[[], tuple[np.ndarray, np.ndarray]] | None = None

    @classmethod
    def deferred(
        cls,
        frame_index: int,
        build: Callable[[], tuple[np.ndarray, np.ndarray]],
        point_count: int,
        replace: bool = False,
    ) -> "MapUpdated":
        """The event whose ``(points, colors)`` ``build()`` returns, ``point_count`` of them."""
        event = cls(frame_index, np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint8), replace)
        event.point_count, event._cloud, event._build = point_count, None, build
        return event

    @property
    def points(self) -> np.ndarray:
        return self._built()[0]

    @property
    def colors(self) -> np.ndarray:
        return self._built()[1]

    def _built(self) -> tuple[np.ndarray, np.ndarray]:
        if self._cloud is None:
            assert self._build is not None  # a deferred event
            self._cloud, self._build = self._build(), None
        return self._cloud

    def __repr__(self) -> str:
        return f"MapUpdated(frame_index={self.frame_index}, {self.point_count} points, replace={self.replace})"


@dataclass
class TrackingLost:
    frame_index: int
    timestamp: float
    reason: str


@dataclass
class TrackingRecovered:
    frame_index: int
    timestamp: float
    reason: str


@dataclass
class TrajectoryFinal:
    """Every frame that has a pose at the end of the run, after the final optimisation.

    ``odometry_poses`` are the same frames' poses before any loop closure corrected them
    (raw odometry, for contrast), when the pipeline keeps them; ``resumptions`` the stamps
    where the run says it resumed after a loss its poses' gaps may not show (an RTAB-Map
    database's new maps).
    """

    frame_indices: np.ndarray
    timestamps: np.ndarray
    poses: np.ndarray
    odometry_poses: np.ndarray | None = None
    resumptions: np.ndarray | None = None


Event = (
    FrameTracked
    | KeyframeAdded
    | FeatureMatches
    | GraphEdge
    | GraphOptimized
    | MapUpdated
    | TrackingLost
    | TrackingRecovered
    | TrajectoryFinal
)
