"""What an RTAB-Map database says beside its poses, in the terms of a run: graph edges and
node statistics (where a new map began is in its trajectory's resumptions).

Shared by the replay of a database over a sequence (:mod:`.replay`) and by a recording of
trajectory files alone (:mod:`.trajectory_files`), so both show one database alike.
"""

from dataclasses import dataclass

import numpy as np

from ..geometry.rtabmap_database import RtabmapDatabase, RtabmapNode
from ..pipelines.edges import EdgeClassifier
from ..pipelines.events import Event, GraphEdge, KeyframeAdded

# An RTAB-Map link kind as the detection a graph edge names; other kinds are not drawn.
LINK_DETECTION = {"neighbor": "odometry", "global_loop": "appearance", "local_space": "proximity", "user": "user"}
REJECTED = "hypothesis rejected by RTAB-Map"


@dataclass(frozen=True)
class NodeEdge:
    """A graph edge ending at a node: a link of the database (accepted) or the loop hypothesis
    RTAB-Map rejected at that node."""

    from_id: int
    to_id: int
    detection: str
    accepted: bool
    reason: str
    score: float = 0.0
    inliers: int = 0


def edges_by_node(database: RtabmapDatabase) -> dict[int, list[NodeEdge]]:
    """Each node's edges from earlier nodes (by stamp): its links, then a hypothesis rejected there.

    A loop closure carries the node's highest hypothesis value and its visual inliers
    (``Loop/Highest_hypothesis_value/``, ``Loop/Visual_inliers/``)."""
    order = {node.id: rank for rank, node in enumerate(database.nodes)}
    by_id = {node.id: node for node in database.nodes}
    edges: dict[int, list[NodeEdge]] = {node.id: [] for node in database.nodes}
    for link in database.links:
        if link.kind not in LINK_DETECTION:
            continue
        older, newer = sorted((link.from_id, link.to_id), key=order.__getitem__)
        stats = by_id[newer].statistics
        loop = LINK_DETECTION[link.kind] == "appearance"
        edges[newer].append(
            NodeEdge(
                older,
                newer,
                LINK_DETECTION[link.kind],
                True,
                f"{link.kind} link",
                stats.get("Loop/Highest_hypothesis_value/", 0.0) if loop else 0.0,
                int(stats.get("Loop/Visual_inliers/", 0)) if loop else 0,
            )
        )
    for node in database.nodes:
        stats = node.statistics
        hypothesis = int(stats.get("Loop/Highest_hypothesis_id/", 0))
        if stats.get("Loop/RejectedHypothesis/", 0) and order.get(hypothesis, len(order)) < order[node.id]:
            edges[node.id].append(
                NodeEdge(
                    hypothesis,
                    node.id,
                    "appearance",
                    False,
                    REJECTED,
                    stats.get("Loop/Highest_hypothesis_value/", 0.0),
                    int(stats.get("Loop/Visual_inliers/", 0)),
                )
            )
    return edges


def graph_events(
    node: RtabmapNode,
    edges: list[NodeEdge],
    frame_index: int,
    timestamp: float,
    pose: np.ndarray,
    classifier: EdgeClassifier,
) -> list[Event]:
    """The node as a keyframe at ``frame_index`` and its ``edges`` (:func:`edges_by_node`) as
    graph edges, classified by ``classifier`` (which learns the node), as a pipeline emits them."""
    classifier.add_node(node.id, node.stamp)
    return [
        KeyframeAdded(node.id, frame_index, timestamp, pose),
        *[
            GraphEdge(
                frame_index,
                edge.from_id,
                edge.to_id,
                edge.accepted,
                edge.reason,
                classifier.kind(edge.from_id, edge.to_id),
                edge.score,
                edge.inliers,
                edge.detection,
            )
            for edge in edges
        ],
    ]


def node_metrics(node: RtabmapNode) -> dict[str, float]:
    """The node's map and the statistics a pipeline's frames carry under the same names."""
    stats = node.statistics
    return {
        "map": float(node.map_id),
        "local_map": stats.get("Odometry/LocalMapSize/", float("nan")),
        "posterior_max": stats.get("Loop/Highest_hypothesis_value/", float("nan")),
    }
