"""The kind of a graph edge, by one rule for every pipeline.

Pipelines add edges for different reasons (an odometry link, a comparison with a recent
node, an appearance match with an old place). Counted together they are not comparable
between pipelines, and only some of them close a loop. An edge between a node and an older
one is:

- ``sequential`` when the older node is the newer one's direct predecessor in creation
  order (odometry, or the predecessor comparison);
- ``local`` when the older node is among the newer one's last ``LOOP_MIN_NODE_GAP``
  predecessors, or was created less than ``LOOP_MIN_AGE_S`` seconds before it;
- ``loop`` otherwise: the older node is outside the recent window in both respects, so
  the edge joins the present to a place the camera left, which is what a loop closure is.
"""

from enum import Enum

LOOP_MIN_NODE_GAP = 10
LOOP_MIN_AGE_S = 5.0


class EdgeKind(str, Enum):
    SEQUENTIAL = "sequential"
    LOCAL = "local"
    LOOP = "loop"


class EdgeClassifier:
    """Remembers each node's creation rank and stamp, and classifies edges between nodes."""

    def __init__(self, min_node_gap: int = LOOP_MIN_NODE_GAP, min_age_s: float = LOOP_MIN_AGE_S):
        self.min_node_gap = min_node_gap
        self.min_age_s = min_age_s
        self._rank: dict[int, int] = {}
        self._stamp: dict[int, float] = {}

    def add_node(self, node_id: int, timestamp: float) -> None:
        self._rank[node_id] = len(self._rank)
        self._stamp[node_id] = timestamp

    def kind(self, node_a: int, node_b: int) -> EdgeKind:
        """The kind of an edge between two nodes already added, in either order."""
        newer, older = (node_a, node_b) if self._rank[node_a] >= self._rank[node_b] else (node_b, node_a)
        gap = self._rank[newer] - self._rank[older]
        if gap <= 1:
            return EdgeKind.SEQUENTIAL
        if gap <= self.min_node_gap or self._stamp[newer] - self._stamp[older] < self.min_age_s:
            return EdgeKind.LOCAL
        return EdgeKind.LOOP
