"""The whole map rebuilt from each node's (or location's) cloud at its current pose."""

from collections.abc import Iterable

import numpy as np

from ..geometry.se3 import transform_points
from .events import MapUpdated


def rebuilt_map(frame_index: int, clouds: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray]],
                max_points: int) -> MapUpdated:
    """A replacing MapUpdated from ``(pose, camera-frame points, colours)`` per node, every
    k-th point kept so that at most ``max_points`` remain."""
    points, colors = [], []
    for pose, node_points, node_colors in clouds:
        points.append(transform_points(pose, node_points))
        colors.append(node_colors)
    if not points:
        return MapUpdated(frame_index, np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint8), replace=True)
    merged_points, merged_colors = np.concatenate(points), np.concatenate(colors)
    stride = max(1, -(-len(merged_points) // max_points))
    return MapUpdated(frame_index, merged_points[::stride].astype(np.float32), merged_colors[::stride], replace=True)
