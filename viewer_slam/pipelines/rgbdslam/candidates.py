"""Which nodes a frame is compared with (RGB-D SLAM v2's three candidate sets).

Recent nodes give odometry, graph neighbours of the last node close small loops, and nodes
sampled from the whole graph find large loop closures and relocalise a lost camera.
"""

from collections.abc import Mapping, Sequence

import numpy as np

PREDECESSOR = "predecessor"
NEIGHBOUR = "neighbour"
SAMPLED = "sampled"


def predecessors(node_ids: Sequence[int], count: int) -> list[int]:
    """The ``count`` most recent nodes, newest first."""
    return list(node_ids[-count:][::-1]) if count > 0 else []


def graph_neighbourhood(adjacency: Mapping[int, set[int]], start: int, depth: int) -> list[int]:
    """Nodes within ``depth`` edges of ``start`` (breadth first, ``start`` excluded), sorted."""
    seen, frontier = {start}, {start}
    for _ in range(depth):
        frontier = {n for node in frontier for n in adjacency.get(node, ())} - seen
        seen |= frontier
    return sorted(seen - {start})


def _sample(pool: list[int], count: int, rng: np.random.Generator) -> list[int]:
    if count <= 0 or not pool:
        return []
    if len(pool) <= count:
        return pool
    return sorted(rng.choice(pool, size=count, replace=False).tolist())


def loop_candidates(node_ids: Sequence[int], adjacency: Mapping[int, set[int]], last_node: int | None,
                    exclude: set[int], neighbor_count: int, sampled_count: int, geodesic_depth: int,
                    rng: np.random.Generator) -> list[tuple[int, str]]:
    """Graph neighbours of ``last_node`` and nodes sampled from the rest of the graph,
    each tagged with its kind, none of them in ``exclude`` (the predecessors)."""
    neighbourhood = [] if last_node is None else graph_neighbourhood(adjacency, last_node, geodesic_depth)
    neighbours = _sample([n for n in neighbourhood if n not in exclude], neighbor_count, rng)
    taken = exclude | set(neighbours)
    sampled = _sample([n for n in node_ids if n not in taken], sampled_count, rng)
    return [(n, NEIGHBOUR) for n in neighbours] + [(n, SAMPLED) for n in sampled]
