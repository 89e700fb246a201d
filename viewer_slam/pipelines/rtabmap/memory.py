"""RTAB-Map's memory: Short-Term, Working and Long-Term Memory of locations.

New locations enter Short-Term Memory (the Mem/STMSize newest, never loop closure
candidates, since they look like the current place anyway) and move on to Working Memory,
where loop closures are searched; a new map moves all of STM to WM at once
(Memory::incrementMapId). Rehearsal gives weight to places seen for long. When an update
takes longer than Rtabmap/TimeThr or WM holds more than Rtabmap/MemoryThr locations,
(locations added + 1) of the least weighted, oldest ones go to Long-Term Memory, out of
the vocabulary and the Bayes filter (Memory::forget); the neighbours of a loop closure
hypothesis come back from LTM (Rtabmap::process, retrieval), so the cost of detection
stays bounded however long the run.
"""

from collections import deque
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from .bayes import PREDICTION_MARGINS
from .vocabulary import Vocabulary


class Link(Enum):
    """What joins two locations (RTAB-Map's Link::Type, the kinds this pipeline makes)."""

    NEIGHBOUR = "neighbour"  # odometry between consecutive locations of a map
    LOOP = "loop"  # a global (appearance) loop closure
    PROXIMITY = "proximity"  # a local loop closure found by space


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
    links: dict[int, Link] = field(default_factory=dict)


def similarity(words_a: np.ndarray, words_b: np.ndarray) -> float:
    """Share of words two locations have in common (counted with multiplicity) relative to
    the larger of the two, as RTAB-Map compares signatures (Signature::compareTo: features
    without a word, -1 here, count in neither)."""
    words_a, words_b = words_a[words_a >= 0], words_b[words_b >= 0]
    if len(words_a) == 0 or len(words_b) == 0:
        return 0.0
    ids_a, counts_a = np.unique(words_a, return_counts=True)
    ids_b, counts_b = np.unique(words_b, return_counts=True)
    _, in_a, in_b = np.intersect1d(ids_a, ids_b, assume_unique=True, return_indices=True)
    return float(np.minimum(counts_a[in_a], counts_b[in_b]).sum() / max(len(words_a), len(words_b)))


class Memory:
    """Locations by id and the memory each is in; keeps the vocabulary's index in step.

    ``age`` is when a WM location entered WM or was last touched (Memory::updateAge),
    counted in map updates; ``last_loop_closure`` is the newest location a global loop
    closure linked to (Memory::_lastGlobalLoopClosureId).
    """

    def __init__(self, vocabulary: Vocabulary, stm_size: int, recent_wm_ratio: float = 0.2):
        self.vocabulary = vocabulary
        self.locations: dict[int, Location] = {}
        self.stm: deque[int] = deque()
        self.wm: list[int] = []
        self.ltm: set[int] = set()
        self.stm_size = stm_size
        self.recent_wm_ratio = recent_wm_ratio
        self.age: dict[int, int] = {}
        self.clock = 0
        self.last_loop_closure: int | None = None

    def add(self, location: Location) -> None:
        """A new location (its words already indexed) joins STM; the oldest overflow to WM."""
        self.clock += 1
        self.locations[location.id] = location
        self.stm.append(location.id)
        while len(self.stm) > self.stm_size:
            self._enter_wm(self.stm.popleft())

    def start_map(self) -> None:
        """A new map begins: every STM location becomes a loop closure candidate."""
        while self.stm:
            self._enter_wm(self.stm.popleft())

    def _enter_wm(self, location_id: int) -> None:
        self.wm.append(location_id)
        self.age[location_id] = self.clock

    def touch(self, location_id: int) -> None:
        """Memory::updateAge: a WM location near the camera counts as recent."""
        if location_id in self.age:
            self.age[location_id] = self.clock

    def link(self, a: int, b: int, kind: Link) -> None:
        self.locations[a].links[b] = kind
        self.locations[b].links[a] = kind
        if kind is Link.LOOP:
            self.last_loop_closure = max(a, b)

    def neighbours(
        self,
        start: int,
        max_margin: int,
        *,
        loops_add_margin: bool = False,
        follow_loops: bool = True,
        follow_proximity: bool = False,
        ltm_budget: int = 0,
        within: set[int] | None = None,
    ) -> dict[int, int]:
        """Memory::getNeighborsId: locations within ``max_margin`` (0: any) neighbour links of
        ``start``, with their margin. Loop links are followed when ``follow_loops`` (proximity
        links too with ``follow_proximity``) and keep the margin unless ``loops_add_margin``.
        Up to ``ltm_budget`` LTM locations (-1: all) are entered, as the original loads them
        from its database; with ``within`` (its ``nodesSet``), only those locations are."""
        found: dict[int, int] = {}
        same_margin: set[int] = set()
        frontier, margin, loaded = {start}, 0, 0
        while (max_margin == 0 or margin < max_margin) and frontier:
            current = sorted(frontier, reverse=True)
            frontier = set()
            position = 0
            while position < len(current):
                location_id = current[position]
                position += 1
                if location_id in found or (within is not None and location_id not in within):
                    continue
                if location_id in self.ltm:
                    if ltm_budget != -1 and loaded >= ltm_budget:
                        continue
                    loaded += 1
                found[location_id] = margin
                for other, kind in self.locations[location_id].links.items():
                    if other in found:
                        continue
                    if kind is Link.NEIGHBOUR or (
                        follow_loops and loops_add_margin and (follow_proximity or kind is Link.LOOP)
                    ):
                        frontier.add(other)
                    elif follow_loops and (follow_proximity or kind is Link.LOOP) and other not in same_margin:
                        same_margin.add(other)
                        current.append(other)
            margin += 1
        return found

    def removable(self, count: int, protected: set[int]) -> list[int]:
        """Memory::getRemovableSignatures: up to ``count`` WM locations to transfer, the least
        weighted first, then the oldest, then the lowest id. Never the protected ones, the
        last loop closure location, a location linked to one in STM, nor (with
        Mem/RecentWmRatio) the locations newer than the last loop closure while they are
        fewer than that share of WM."""
        stm = set(self.stm)
        last = self.last_loop_closure if self.last_loop_closure not in stm else None
        recent_limit = int(self.recent_wm_ratio * len(self.wm))
        recent = sum(1 for i in self.wm if i >= last) if last is not None else 0
        recent_immune = 1 < recent < recent_limit
        candidates = sorted(
            (self.locations[i].weight, self.age[i], i)
            for i in self.wm
            if i != last
            and not (recent_immune and last is not None and i > last)
            and i not in protected
            and not stm.intersection(self.locations[i].links)
        )
        chosen: list[int] = []
        recent_moved = 0
        for _, _, location_id in candidates:
            if not recent_immune:
                chosen.append(location_id)
                if last is not None and location_id > last:
                    recent_moved += 1
                    recent_immune = recent - recent_moved < recent_limit
            elif last is None or location_id < last:
                chosen.append(location_id)
            if len(chosen) >= count:
                break
        return chosen

    def forget(self, count: int, protected: set[int]) -> list[int]:
        """Memory::forget: move :meth:`removable` locations to LTM; returns them."""
        moved = self.removable(count, protected)
        for location_id in moved:
            self.vocabulary.unindex(location_id, self.locations[location_id].words)
            self.ltm.add(location_id)
            del self.age[location_id]
            if location_id == self.last_loop_closure:
                self.last_loop_closure = None
        gone = set(moved)
        self.wm = [i for i in self.wm if i not in gone]
        return moved

    def retrieval_order(self, around: int, ltm_budget: int) -> tuple[list[int], set[int]]:
        """Rtabmap::process, retrieval: the neighbours of a loop closure hypothesis in the
        order they would come back (by time, then through loop closures; nearest margin
        first, newest first within one; STM excluded), and the time neighbours, which are
        immunised from transfer. Each search enters at most ``ltm_budget`` LTM locations."""
        stm = set(self.stm)
        order: list[int] = []
        immune: set[int] = set()
        for through_loops in (False, True):
            margins = self.neighbours(
                around,
                PREDICTION_MARGINS,
                loops_add_margin=True,
                follow_loops=through_loops,
                follow_proximity=through_loops,
                ltm_budget=ltm_budget,
            )
            for margin in range(PREDICTION_MARGINS):
                ring = sorted(
                    (i for i, m in margins.items() if m == margin and i not in stm and i not in order), reverse=True
                )
                order.extend(ring)
                if not through_loops:
                    immune.update(ring)
        return order, immune

    def retrieve(self, ids: list[int], count: int) -> list[int]:
        """Memory::reactivateSignatures: bring back the first ``count`` LTM locations of ``ids``."""
        retrieved = [i for i in ids if i in self.ltm][:count]
        for location_id in retrieved:
            self.ltm.discard(location_id)
            self.vocabulary.index(location_id, self.locations[location_id].words)
            self._enter_wm(location_id)
        self.wm.sort()
        return retrieved
