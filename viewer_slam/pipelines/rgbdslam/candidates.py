"""Which nodes a frame is compared with: v2's ``GraphManager::getPotentialEdgeTargetsWithDijkstra``.

Three sets, drawn in this order: the ``sequential`` nodes just before the predecessor;
graph neighbours of the predecessor within ``geodesic_depth`` edges, except the sequential
ones, sampled without replacement with probability proportional to their id distance from
the predecessor (far neighbours are likelier: they close larger loops); and keyframes
sampled uniformly from the whole graph (loop closures, relocalisation). While the graph
has no more nodes than the three counts together, every node is compared.
"""

from collections.abc import Mapping, Sequence

import numpy as np

PREDECESSOR = "predecessor"
NEIGHBOUR = "neighbour"
SAMPLED = "sampled"


def graph_neighbourhood(adjacency: Mapping[int, set[int]], start: int, depth: int) -> list[int]:
    """Nodes within ``depth`` edges of ``start`` (breadth first, ``start`` excluded), sorted."""
    seen, frontier = {start}, {start}
    for _ in range(depth):
        frontier = {n for node in frontier for n in adjacency.get(node, ())} - seen
        seen |= frontier
    return sorted(seen - {start})


def neighbour_weights(neighbourhood: Sequence[int], predecessor: int, sequential: int) -> dict[int, int]:
    """Sampling weight ``|predecessor - id|`` of each neighbour that is not one of the
    ``sequential`` nodes before the predecessor."""
    return {n: abs(predecessor - n) for n in neighbourhood if n < predecessor - sequential or n > predecessor}


def weighted_sample(weights: Mapping[int, int], count: int, rng: np.random.Generator) -> list[int]:
    """``count`` ids drawn without replacement, each draw with probability weight / remaining total."""
    remaining = dict(sorted(weights.items()))
    drawn: list[int] = []
    while len(drawn) < count and remaining and sum(remaining.values()) > 0:
        pick = int(rng.integers(sum(remaining.values())))
        for node, weight in remaining.items():
            pick -= weight
            if pick < 0:
                drawn.append(node)
                del remaining[node]
                break
    return drawn


def edge_targets(
    node_ids: Sequence[int],
    adjacency: Mapping[int, set[int]],
    keyframes: Sequence[int],
    predecessor: int,
    include_predecessor: bool,
    sequential: int,
    neighbours: int,
    sampled: int,
    geodesic_depth: int,
    rng: np.random.Generator,
) -> list[tuple[int, str]]:
    """The nodes to compare a new frame with, each tagged with how it was chosen.

    ``node_ids`` are consecutive from 0; ``predecessor`` is the node the sequential ones
    precede (the newest, or the one the frame already matched); it is itself a target
    only with ``include_predecessor``.
    """
    if len(node_ids) <= sequential + neighbours + sampled or len(node_ids) <= 1:
        sequential, neighbours, sampled = sequential + neighbours + sampled, 0, 0
        predecessor = node_ids[-1]
    chosen = [predecessor - i for i in range(1, sequential + 1) if predecessor - i >= 0]
    targets = [(n, PREDECESSOR) for n in chosen]
    if neighbours > 0:
        weights = neighbour_weights(
            graph_neighbourhood(adjacency, predecessor, geodesic_depth), predecessor, sequential
        )
        drawn = weighted_sample(weights, sequential + neighbours - len(chosen), rng)
        chosen += drawn
        targets += [(n, NEIGHBOUR) for n in drawn]
    if sampled > 0:
        pool = [k for k in keyframes if k not in chosen and not (include_predecessor and k == predecessor)]
        count = min(sampled + neighbours + sequential - len(chosen), len(pool))
        drawn = sorted(rng.choice(pool, size=count, replace=False).tolist()) if count > 0 else []
        targets += [(n, SAMPLED) for n in drawn]
    if include_predecessor:
        targets.insert(0, (predecessor, PREDECESSOR))
    return targets
