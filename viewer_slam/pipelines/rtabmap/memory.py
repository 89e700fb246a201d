"""RTAB-Map's memory: Short-Term, Working and Long-Term Memory of locations.

New locations enter Short-Term Memory (Mem/STMSize newest, never loop closure candidates,
since they look like the current place anyway) and move on to Working Memory, where loop
closures are searched. Rehearsal gives weight to places seen for long. With a memory or
time budget, the least weighted, oldest locations go to Long-Term Memory, out of the
vocabulary and the Bayes filter, and the neighbours of a loop closure hypothesis come
back, so the cost of detection stays bounded however long the run.
"""

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from .vocabulary import Vocabulary


@dataclass
class Location:
    """A graph node: where the camera was, what it saw (strongest features, their words)
    and a coarse coloured cloud for the map."""

    id: int
    session: int
    frame_index: int
    timestamp: float
    odometry_pose: np.ndarray
    keypoints: np.ndarray
    descriptors: np.ndarray
    points: np.ndarray
    words: np.ndarray
    cloud_points: np.ndarray
    cloud_colors: np.ndarray
    weight: int = 0
    links: set[int] = field(default_factory=set)


def similarity(words_a: np.ndarray, words_b: np.ndarray) -> float:
    """Share of words two locations have in common (counted with multiplicity) relative to
    the larger of the two, as RTAB-Map compares signatures."""
    if len(words_a) == 0 or len(words_b) == 0:
        return 0.0
    ids_a, counts_a = np.unique(words_a, return_counts=True)
    ids_b, counts_b = np.unique(words_b, return_counts=True)
    _, in_a, in_b = np.intersect1d(ids_a, ids_b, assume_unique=True, return_indices=True)
    return float(np.minimum(counts_a[in_a], counts_b[in_b]).sum() / max(len(words_a), len(words_b)))


class Memory:
    """Locations by id and the memory each is in; keeps the vocabulary's index in step."""

    def __init__(self, vocabulary: Vocabulary, stm_size: int):
        self.vocabulary = vocabulary
        self.locations: dict[int, Location] = {}
        self.stm: deque[int] = deque()
        self.wm: list[int] = []
        self.ltm: set[int] = set()
        self.stm_size = stm_size

    def add(self, location: Location) -> None:
        """A new location (its words already indexed) joins STM; the oldest overflow to WM."""
        self.locations[location.id] = location
        self.stm.append(location.id)
        while len(self.stm) > self.stm_size:
            self.wm.append(self.stm.popleft())

    def link(self, a: int, b: int) -> None:
        self.locations[a].links.add(b)
        self.locations[b].links.add(a)

    def transfer(self, limit: int, protected: set[int]) -> list[int]:
        """Move the least weighted, oldest unprotected WM locations to LTM until at most
        ``limit`` remain; returns them."""
        excess = len(self.wm) - limit
        if excess <= 0:
            return []
        order = sorted((self.locations[i].weight, i) for i in self.wm if i not in protected)
        moved = [i for _, i in order[:excess]]
        for location_id in moved:
            self.vocabulary.unindex(location_id, self.locations[location_id].words)
            self.ltm.add(location_id)
        gone = set(moved)
        self.wm = [i for i in self.wm if i not in gone]
        return moved

    def retrieve(self, around: int, count: int) -> list[int]:
        """Bring back up to ``count`` LTM locations nearest to ``around`` in the graph
        (breadth first), so a revisited place's neighbourhood is searchable again."""
        retrieved, seen, frontier = [], {around}, [around]
        while frontier and len(retrieved) < count:
            neighbours = sorted({n for i in frontier for n in self.locations[i].links} - seen)
            seen.update(neighbours)
            for location_id in neighbours:
                if location_id in self.ltm and len(retrieved) < count:
                    retrieved.append(location_id)
            frontier = neighbours
        for location_id in retrieved:
            self.ltm.discard(location_id)
            self.vocabulary.index(location_id, self.locations[location_id].words)
        self.wm = sorted(self.wm + retrieved)
        return retrieved
