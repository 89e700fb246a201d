"""Disconnected pieces of the pose graph and how an edge between two of them joins them.

Ours, not v2's (``viewslam_new_segment_after_lost_frames``, off by default): after a
kidnap the camera may track in a new segment anchored at the last known pose; the first
edge to the old map tells where the new segment really lies. The newer segment is
then moved rigidly onto the older one (so the optimiser starts at the solution, not at
a guess that may be metres off) and its anchor prior is dropped.
"""

import numpy as np

from ...backend.pose_graph import PoseGraph
from ...geometry.se3 import invert


class Segments:
    """Union-find over segments, each named by its anchor node's id."""

    def __init__(self):
        self.parent: dict[int, int] = {}

    def add(self, anchor: int) -> None:
        self.parent[anchor] = anchor

    def root(self, segment: int) -> int:
        while self.parent[segment] != segment:
            self.parent[segment] = self.parent[self.parent[segment]]
            segment = self.parent[segment]
        return segment

    def join(
        self, graph: PoseGraph, node_segment: dict[int, int], from_id: int, to_id: int, relative: np.ndarray
    ) -> bool:
        """Merge the segments of ``from_id`` and ``to_id`` given the edge ``relative``
        (``T_from^-1 T_to``): the newer segment moves onto the older. False if already one."""
        from_root, to_root = self.root(node_segment[from_id]), self.root(node_segment[to_id])
        if from_root == to_root:
            return False
        older, newer = sorted((from_root, to_root))
        if newer == to_root:
            correction = graph.poses[from_id] @ relative @ invert(graph.poses[to_id])
        else:
            correction = graph.poses[to_id] @ invert(relative) @ invert(graph.poses[from_id])
        for node_id, segment in node_segment.items():
            if self.root(segment) == newer:
                graph.poses[node_id] = correction @ graph.poses[node_id]
        graph.remove_prior(newer)
        self.parent[newer] = older
        return True
