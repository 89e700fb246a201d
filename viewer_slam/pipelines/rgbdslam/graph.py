"""RGB-D SLAM's graph: its nodes, their pose graph, adjacency, keyframes, odometry and segments.

v2 keeps these in its ``GraphManager`` (``graph_``, the g2o optimizer, ``keyframe_ids_``);
here they are one object so that the pipeline only decides what to add and compare.
"""

import numpy as np

from ...backend.pose_graph import CHOLESKY, PCG, Edge, PoseGraph
from ...geometry.camera import Camera
from ..edges import EdgeClassifier
from ..events import MapUpdated
from ..maps import rebuilt_map
from .motion import g2o_information
from .node import Node
from .segments import Segments

# v2 puts g2o's RobustKernelHuber (delta 1, on the Mahalanobis distance) on every edge.
HUBER_DELTA = 1.0
MAX_MAP_POINTS = 200_000


class NodeGraph:
    """Nodes in creation order (ids 0, 1, ...), each with a pose in ``poses``, its
    odometry-only pose, the segment it belongs to, and its neighbours by edge."""

    def __init__(self, backend_solver: str):
        # v2's backend_solver: g2o's PCG, or sparse Cholesky (cholmod, csparse), here GTSAM's.
        linear_solver = PCG if backend_solver == "pcg" else CHOLESKY
        self.poses = PoseGraph(huber_threshold=HUBER_DELTA, linear_solver=linear_solver)
        self.nodes: dict[int, Node] = {}
        self.order: list[int] = []
        self.adjacency: dict[int, set[int]] = {}
        self.odometry: dict[int, np.ndarray] = {}
        self.segment: dict[int, int] = {}
        self.keyframes: list[int] = []
        self.segments = Segments()
        self.kinds = EdgeClassifier()
        self.clouds: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}

    def __len__(self) -> int:
        return len(self.order)

    @property
    def newest(self) -> Node:
        return self.nodes[self.order[-1]]

    def add(self, node: Node, pose: np.ndarray, odometry: np.ndarray) -> None:
        self.nodes[node.node_id] = node
        self.order.append(node.node_id)
        self.adjacency[node.node_id] = set()
        self.segment[node.node_id] = node.segment
        self.odometry[node.node_id] = odometry
        self.kinds.add_node(node.node_id, node.timestamp)
        self.poses.add_node(node.node_id, pose)

    def connect(self, from_id: int, to_id: int, relative: np.ndarray, information: np.ndarray) -> bool:
        """Add the edge ``relative = T_from^-1 T_to``; True if it joined two segments."""
        self.poses.add_edge(Edge(from_id, to_id, relative, information, robust=True))
        self.adjacency[from_id].add(to_id)
        self.adjacency[to_id].add(from_id)
        return self.segments.join(self.poses, self.segment, from_id, to_id, relative)

    def prune_edges_with_error_above(self, threshold: float) -> int:
        """v2's ``pruneEdgesWithErrorAbove``: every edge whose squared Mahalanobis error
        exceeds ``threshold`` is set to no motion; between consecutive nodes it gets the
        information I (a zero-motion assumption), otherwise it is dropped (v2 leaves it with
        information 1e-100). Returns how many edges were pruned."""
        pruned = [edge for edge in self.poses.edges if self.poses.edge_chi2(edge) > threshold]
        for edge in pruned:
            self.poses.remove_edge(edge)
            if abs(edge.from_id - edge.to_id) == 1:
                self.poses.add_edge(Edge(edge.from_id, edge.to_id, np.eye(4), g2o_information(1.0), robust=True))
            else:
                self.adjacency[edge.from_id].discard(edge.to_id)
                self.adjacency[edge.to_id].discard(edge.from_id)
        return len(pruned)

    def map(self, frame_index: int, camera: Camera) -> MapUpdated:
        """The whole map from every node that has a measured pose (v2 does not render
        no-motion nodes), thinned to at most MAX_MAP_POINTS."""
        shown = [node for node in self.nodes.values() if node.measured_pose]
        samples = sum(node.depth_samples for node in shown)
        step = max(1, int(np.ceil(np.sqrt(samples / MAX_MAP_POINTS))))
        return rebuilt_map(
            frame_index,
            ((self.poses.poses[node.node_id], *self._cloud(node, camera, step)) for node in shown),
            MAX_MAP_POINTS,
        )

    def _cloud(self, node: Node, camera: Camera, step: int) -> tuple[np.ndarray, np.ndarray]:
        """The node's camera-frame cloud at ``step``, kept until the step changes: only the
        poses change from one rebuild to the next."""
        cached = self.clouds.get(node.node_id)
        if cached is None or cached[0] != step:
            cached = self.clouds[node.node_id] = (step, *node.cloud(camera, step))
        return cached[1], cached[2]
