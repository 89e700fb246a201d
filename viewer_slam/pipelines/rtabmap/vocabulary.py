"""The incremental visual vocabulary: words, inverted index and tf-idf scores.

As in RTAB-Map, words are not trained offline: a location's descriptor becomes an
existing word when it passes the ratio test (Kp/NndrRatio) against the active words, and
a new word otherwise. Only the words of locations in Working Memory are active, so Long-
Term Memory bounds the search; a retrieved location brings its words back.

Nearest words come from a FLANN LSH index (the binary-descriptor index), rebuilt once
enough words are waiting, plus an exhaustive search over the words added since. OpenCV
shuffles the LSH hash bits with its global generator, reseeded with the run's seed before
each build, so the words found do not depend on what ran before in the process.
"""

from collections import defaultdict

import cv2
import numpy as np

FLANN_INDEX_LSH = 6
LSH_PARAMS: dict[str, bool | int | float | str] = {
    "algorithm": FLANN_INDEX_LSH,
    "table_number": 4,
    "key_size": 16,
    "multi_probe_level": 1,
}
LSH_CHECKS: dict[str, bool | int | float | str] = {"checks": 32}
# Words searched exhaustively before the LSH index is rebuilt over all active words.
REBUILD_PENDING = 1000
FAR = np.iinfo(np.int32).max


def two_nearest(query: np.ndarray, train: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exhaustive Hamming distances ``(Q, 2)`` and indices ``(Q, 2)`` of the two nearest
    rows of ``train`` (distance FAR where ``train`` has fewer than two rows)."""
    distances = np.full((len(query), 2), FAR, np.int64)
    indices = np.zeros((len(query), 2), int)
    if len(train) == 0 or len(query) == 0:
        return distances, indices
    for row, pair in enumerate(cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(query, train, k=2)):
        for column, match in enumerate(pair):
            distances[row, column], indices[row, column] = match.distance, match.trainIdx
    return distances, indices


class Vocabulary:
    """Word descriptors, which locations hold each word, and how often."""

    def __init__(self, nndr: float, seed: int = 0):
        self.nndr = nndr
        self.seed = seed
        self._descriptors = np.zeros((0, 32), np.uint8)
        self._postings: dict[int, dict[int, int]] = defaultdict(dict)  # word -> {location: count}
        self._sizes: dict[int, int] = {}  # location -> features held, quantised or not (Memory::getNi)
        self._references: dict[int, int] = {}  # location -> features quantised to a word
        self._active = np.zeros(0, bool)  # held by an indexed location
        self._in_lsh = np.zeros(0, bool)
        self._index: cv2.flann.Index | None = None
        self._indexed = np.zeros(0, int)  # word id of each row of the LSH index
        self._pending: set[int] = set()  # active words not in the LSH index

    def __len__(self) -> int:
        """Active words: those held by at least one indexed location."""
        return len(self._postings)

    def mean_words_per_location(self) -> int:
        """Word references per indexed location, rounded down (Memory's meanWordsPerLocation:
        the dictionary's active references over the STM and WM locations)."""
        return sum(self._references.values()) // len(self._references) if self._references else 0

    def quantize(self, descriptors: np.ndarray) -> np.ndarray:
        """Word id of each descriptor, -1 where no active word passes the ratio test."""
        words = np.full(len(descriptors), -1)
        if len(descriptors) == 0:
            return words
        if len(self._pending) > REBUILD_PENDING:
            self._rebuild()
        pending = np.array(sorted(self._pending), dtype=int)
        distances, nearest = two_nearest(descriptors, self._descriptors[pending])
        candidates = [distances, pending[nearest] if len(pending) else nearest]
        if self._index is not None:
            rows, indexed_distances = self._index.knnSearch(descriptors, 2, params=LSH_CHECKS)
            ids = self._indexed[np.clip(rows, 0, len(self._indexed) - 1)]
            valid = (rows >= 0) & self._active[ids]
            candidates = [
                np.hstack([distances, np.where(valid, indexed_distances, FAR)]),
                np.hstack([candidates[1], ids]),
            ]
        distances, ids = candidates
        order = np.argsort(distances, axis=1, kind="stable")[:, :2]
        best = np.take_along_axis(distances, order, axis=1)
        passes = (best[:, 0] < FAR) & (best[:, 0] < self.nndr * best[:, 1])
        words[passes] = np.take_along_axis(ids, order, axis=1)[passes, 0]
        return words

    def add_location(self, location: int, descriptors: np.ndarray, quantized: np.ndarray) -> np.ndarray:
        """Quantise the ``quantized`` rows of a new location's descriptors, creating words for
        the unmatched ones, and index the location; returns the word id of each descriptor,
        -1 for the rows left out (Memory::createSignature quantises the Kp/MaxFeatures
        strongest of the features a location keeps)."""
        words = np.full(len(descriptors), -1)
        chosen = descriptors[quantized]
        found = self.quantize(chosen)
        new = np.flatnonzero(found < 0)
        found[new] = len(self._descriptors) + np.arange(len(new))
        words[quantized] = found
        self._descriptors = np.concatenate([self._descriptors, chosen[new]])
        self._active = np.concatenate([self._active, np.zeros(len(new), bool)])
        self._in_lsh = np.concatenate([self._in_lsh, np.zeros(len(new), bool)])
        self.index(location, words)
        return words

    def index(self, location: int, words: np.ndarray) -> None:
        """Make ``location`` (and its words; -1 marks a feature with none) searchable."""
        ids, counts = np.unique(words[words >= 0], return_counts=True)
        for word, count in zip(ids.tolist(), counts.tolist()):
            if not self._active[word]:
                self._active[word] = True
                if not self._in_lsh[word]:
                    self._pending.add(word)
            self._postings[word][location] = count
        self._sizes[location] = len(words)
        self._references[location] = int(counts.sum())

    def unindex(self, location: int, words: np.ndarray) -> None:
        """Remove ``location`` from the index; words no indexed location holds go inactive."""
        for word in np.unique(words[words >= 0]).tolist():
            postings = self._postings[word]
            postings.pop(location, None)
            if not postings:
                del self._postings[word]
                self._active[word] = False
                self._pending.discard(word)
        self._sizes.pop(location, None)
        self._references.pop(location, None)

    def _rebuild(self) -> None:
        self._indexed = np.flatnonzero(self._active)
        self._in_lsh[:] = False
        self._in_lsh[self._indexed] = True
        cv2.setRNGSeed(self.seed)
        self._index = cv2.flann.Index(self._descriptors[self._indexed], LSH_PARAMS)
        self._pending.clear()

    def scores(self, words: np.ndarray, candidates: list[int]) -> np.ndarray:
        """tf-idf score of each candidate location for a query's words:
        sum over shared words of (count in location / location size) * log10(N / locations holding it),
        N the indexed locations (Memory::computeLikelihood)."""
        position = {location: i for i, location in enumerate(candidates)}
        scores = np.zeros(len(candidates))
        indexed = len(self._sizes)
        for word in np.unique(words[words >= 0]).tolist():
            postings = self._postings.get(word)
            if not postings:
                continue
            idf = np.log10(indexed / len(postings))
            for location, count in postings.items():
                i = position.get(location)
                if i is not None:
                    scores[i] += count / self._sizes[location] * idf
        return scores
