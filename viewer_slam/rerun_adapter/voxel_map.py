"""The map point cloud a recording shows: everything a pipeline added, voxel-downsampled."""

import numpy as np

from ..open3d_loader import import_open3d
from ..pipelines.events import MapUpdated

MAX_PENDING_POINTS = 200_000


class VoxelMap:
    """Accumulates map points and keeps at most one (averaged) point per voxel.

    Additions wait, raw, until the cloud is read (the recorder reads it only when a
    snapshot is due) or until ``MAX_PENDING_POINTS`` of them wait, so the downsampling
    runs once per snapshot rather than once per keyframe. When the cloud outgrows
    ``max_points`` the voxel grows by half, so a long sequence costs a bounded number of
    points per snapshot rather than one per pixel ever seen.
    """

    def __init__(self, voxel_size: float = 0.04, max_points: int = 40_000):
        self.voxel_size = voxel_size
        self.max_points = max_points
        self._points = np.zeros((0, 3))
        self._colors = np.zeros((0, 3), dtype=np.uint8)
        self._pending: list[MapUpdated] = []
        self._pending_points = 0
        self._kept_share = 1.0  # of the points the last downsampling received

    def update(self, points: np.ndarray, colors: np.ndarray, replace: bool = False) -> None:
        """Add ``points`` with their ``colors`` (or replace the map with them)."""
        self.add(
            MapUpdated(
                0,
                np.asarray(points, dtype=np.float64).reshape(-1, 3),
                np.asarray(colors, dtype=np.uint8).reshape(-1, 3),
                replace,
            )
        )

    def add(self, update: MapUpdated) -> None:
        """Add a pipeline's map update; a deferred one (:meth:`MapUpdated.deferred`) is only
        computed if it is still part of the map when the cloud is next read."""
        if update.replace:
            self._points, self._colors = self._points[:0], self._colors[:0]
            self._pending, self._pending_points = [], 0
        self._pending.append(update)
        self._pending_points += update.point_count
        if self._pending_points > MAX_PENDING_POINTS:
            self._fold()

    @property
    def size_estimate(self) -> int:
        """The number of points after downsampling, estimated without doing it."""
        return len(self._points) + round(self._kept_share * self._pending_points)

    @property
    def points(self) -> np.ndarray:
        self._fold()
        return self._points

    @property
    def colors(self) -> np.ndarray:
        self._fold()
        return self._colors

    def __len__(self) -> int:
        return len(self.points)

    def _fold(self) -> None:
        """Downsample the cloud together with the additions that wait."""
        if not self._pending:
            return
        points = np.concatenate(
            [self._points, *(np.asarray(u.points, dtype=np.float64).reshape(-1, 3) for u in self._pending)]
        )
        colors = (
            np.concatenate(
                [self._colors, *(np.asarray(u.colors, dtype=np.uint8).reshape(-1, 3) for u in self._pending)]
            ).astype(np.float64)
            / 255.0
        )
        self._pending, self._pending_points = [], 0
        o3d = import_open3d()
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        cloud.colors = o3d.utility.Vector3dVector(colors)
        downsampled = cloud.voxel_down_sample(self.voxel_size)
        while len(downsampled.points) > self.max_points:
            self.voxel_size *= 1.5
            downsampled = downsampled.voxel_down_sample(self.voxel_size)
        self._kept_share = len(downsampled.points) / max(len(points), 1)
        self._points = np.asarray(downsampled.points)
        self._colors = np.round(np.asarray(downsampled.colors) * 255).astype(np.uint8)
