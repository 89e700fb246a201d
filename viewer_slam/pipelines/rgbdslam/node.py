"""Graph nodes: the frames kept for matching, mapping and the environment measurement model."""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ...geometry.camera import Camera
from .motion import MeasuredFeatures

# Nodes keep every MAP_STEP-th pixel of their depth and colour: enough for the EMM and the
# point-cloud view, small enough that thousands of nodes fit in memory.
MAP_STEP = 8


@dataclass
class Node:
    """A graph node. ``measured`` are its keypoints that have a 3D point; ``depth``/``colors``
    are the frame's depth and colour subsampled by ``MAP_STEP``; ``segment`` names the
    connected piece of graph the node was created in; ``measured_pose`` is False for a node
    kept under the no-motion assumption (v2's ``valid_tf_estimate_``), which the map leaves out."""

    node_id: int
    frame_index: int
    timestamp: float
    measured: MeasuredFeatures
    depth: np.ndarray
    colors: np.ndarray
    segment: int
    measured_pose: bool = True

    @classmethod
    def from_frame(
        cls,
        node_id: int,
        frame_index: int,
        timestamp: float,
        measured: MeasuredFeatures,
        rgb: np.ndarray,
        depth: np.ndarray,
        segment: int,
        measured_pose: bool = True,
    ) -> "Node":
        return cls(
            node_id,
            frame_index,
            timestamp,
            measured,
            np.ascontiguousarray(depth[::MAP_STEP, ::MAP_STEP]),
            np.ascontiguousarray(rgb[::MAP_STEP, ::MAP_STEP]),
            segment,
            measured_pose,
        )

    @cached_property
    def depth_samples(self) -> int:
        """How many of the kept depth pixels are non-zero (the map's size before thinning)."""
        return int(np.count_nonzero(self.depth))

    def cloud(self, camera: Camera, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Camera-frame points and their colours from the kept depth, every ``step``-th sample."""
        rows, cols = np.nonzero(self.depth[::step, ::step] > 0)
        rows, cols = rows * step, cols * step
        pixels = np.stack([cols, rows], axis=1) * MAP_STEP
        points = camera.backproject(pixels.astype(np.float64), self.depth[rows, cols])
        return points, self.colors[rows, cols]
