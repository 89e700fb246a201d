"""The whole map rebuilt from each node's (or location's) cloud at its current pose."""

from collections.abc import Iterable

import numpy as np

from ..geometry.se3 import transform_points
from .events import MapUpdated


def rebuilt_map(
    frame_index: int, clouds: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray]], max_points: int
) -> MapUpdated:
    """A replacing MapUpdated from ``(pose, camera-frame points, colours)`` per node, every
    k-th point kept so that at most ``max_points`` remain; computed when a sink reads it
    (:meth:`MapUpdated.deferred`), from the poses as they are now."""
    clouds = [(np.array(pose), points, colors) for pose, points, colors in clouds]
    total = sum(len(points) for _, points, _ in clouds)
    if not total:
        return MapUpdated(frame_index, np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint8), replace=True)
    stride = max(1, -(-total // max_points))
    return MapUpdated.deferred(frame_index, lambda: _merged(clouds, stride), -(-total // stride), replace=True)


def _merged(clouds: list[tuple[np.ndarray, np.ndarray, np.ndarray]], stride: int) -> tuple[np.ndarray, np.ndarray]:
    """Every ``stride``-th point of the clouds moved to their poses, as float32, with its colour."""
    points = np.concatenate([transform_points(pose, node_points) for pose, node_points, _ in clouds])
    colors = np.concatenate([node_colors for _, _, node_colors in clouds])
    return points[::stride].astype(np.float32), colors[::stride]
