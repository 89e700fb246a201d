"""RegistrationVis's matching without a motion guess: through a visual-word dictionary.

RTAB-Map puts the reference's descriptors in a ``VWDictionary`` under their word ids and
quantises the other side's descriptors into it (``VWDictionary::addNewWords``, with
Kp/NewWordsComparedTogether off, as RegistrationVis sets it): a descriptor takes its nearest
word when that passes the ratio test Vis/CorNNDR against the second nearest (it fails when
``best > ratio · second``), and every word taken by two or more descriptors is dropped with
all of them (``uMultimapToMapUnique``), so those descriptors take part in neither the
registration nor, for the odometry, Reg/RepeatOnce's second registration.

Which two words are "nearest" is Vis/CorNNType's: 1 (the default, kNNFlannKdTree) asks
FLANN's randomised k-d trees (4 trees, 32 checks: ``FlannIndex::buildKDTreeIndex`` and
``KNN_CHECKS``) over the descriptors' bits as 0/1 floats under L1, i.e. Hamming distances
found approximately; 3 (kNNBruteForce) searches exactly. The approximate search passes ratio
tests the exact one fails (its second neighbour is often not the true second): on the
synthetic 360_kidnap after a covering, 81–98 matches per frame where the exact search finds
50–66 (RTAB-Map 0.23.8: 83–126), more of them wrong, so PnP RANSAC finds a pose only once
enough of the view is mapped, where the original resumes tracking.

RTAB-Map's FLANN draws each build's trees from ``std::random_device``, so its matches vary
from frame to frame and from run to run (on 360_kidnap, frame 1 keeps 852, 854 or 859 of its
features in three runs of RTAB-Map 0.23.8). OpenCV's FLANN draws them from the calling thread's
``cv::theRNG()``, which :class:`TreeSeeds` seeds before every build with a fresh draw from the
run's seed: the trees differ from build to build as the original's do, and the same seed gives
the same matches on every machine, another seed another draw of them.
"""

from dataclasses import dataclass

import cv2
import numpy as np

KD_TREE_INDEX = 1  # FLANN_INDEX_KDTREE
KD_TREES = 4
KNN_CHECKS = 32
FLANN_L1 = 2  # cvflann::FLANN_DIST_L1
KD_TREE, BRUTE_FORCE = 1, 3  # Vis/CorNNType


@dataclass
class WordMatches:
    """``query`` and ``train``: the matches (indices of the descriptors quantised and of the
    dictionary's words) that kept a word of their own; ``kept``: the query descriptors whose
    word, matched or new, no other took."""

    query: np.ndarray
    train: np.ndarray
    kept: np.ndarray


class TreeSeeds:
    """The seed of each k-d tree build in turn, drawn from the run's seed (module docstring)."""

    def __init__(self, seed: int):
        self._draws = np.random.default_rng(seed)

    def next(self) -> int:
        return int(self._draws.integers(1, 2**31))


def two_nearest(
    query: np.ndarray, words: np.ndarray, nn_type: int, tree_seeds: TreeSeeds
) -> tuple[np.ndarray, np.ndarray]:
    """Each query descriptor's two nearest words and their Hamming distances, by Vis/CorNNType."""
    if nn_type == BRUTE_FORCE:
        distances, nearest = cv2.batchDistance(query, words, -1, normType=cv2.NORM_HAMMING, K=2)
        return nearest.astype(int), distances.astype(np.float64)
    cv2.setRNGSeed(tree_seeds.next())
    index = cv2.flann.Index(
        np.unpackbits(words, axis=1).astype(np.float32),
        {"algorithm": KD_TREE_INDEX, "trees": KD_TREES},
        distType=FLANN_L1,
    )
    nearest, distances = index.knnSearch(
        np.unpackbits(query, axis=1).astype(np.float32), 2, params={"checks": KNN_CHECKS}
    )
    return nearest.astype(int), distances.astype(np.float64)


def word_matches(
    query: np.ndarray, words: np.ndarray, ratio: float, nn_type: int, tree_seeds: TreeSeeds
) -> WordMatches:
    """The query descriptors (binary, one per row) quantised into the words (module docstring)."""
    count = len(query)
    if count == 0 or len(words) < 2:
        return WordMatches(np.zeros(0, int), np.zeros(0, int), np.arange(count))
    nearest, distances = two_nearest(query, words, nn_type, tree_seeds)
    passing = ~(distances[:, 0] > ratio * distances[:, 1])
    word = np.where(passing, nearest[:, 0], -1 - np.arange(count))  # a failing descriptor: a new word of its own
    taken = np.bincount(word[passing], minlength=len(words))
    alone = ~passing | (taken[np.where(passing, word, 0)] == 1)
    matched = np.flatnonzero(passing & alone)
    return WordMatches(matched, word[matched], np.flatnonzero(alone))
