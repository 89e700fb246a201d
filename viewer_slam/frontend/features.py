"""Keypoint detection, description, back-projection to 3D and ratio-test matching.

One :class:`FeatureExtractor` serves both pipelines: RGB-D SLAM's detectors (ORB spread
with a detector grid, SIFT, and what OpenCV offers cheaply) and RTAB-Map's GFTT corners
with ORB or BRIEF descriptors (Kp/DetectorStrategy 8 and 6).
"""

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..geometry.camera import Camera

BINARY_DESCRIPTORS = {"ORB", "BRISK", "AKAZE", "GFTT_ORB", "GFTT_BRIEF"}
DETECTORS = ("ORB", "SIFT", "AKAZE", "BRISK", "GFTT_ORB", "GFTT_BRIEF")


@dataclass
class Features:
    """Keypoints ``(N, 2)`` float32 pixels, descriptors ``(N, D)``, responses ``(N,)``, and
    camera-frame 3D points ``(N, 3)`` that are NaN where the depth is missing or out of range.
    """

    keypoints: np.ndarray
    descriptors: np.ndarray
    responses: np.ndarray
    points: np.ndarray
    binary: bool

    def __len__(self) -> int:
        return len(self.keypoints)

    @property
    def has_depth(self) -> np.ndarray:
        return ~np.isnan(self.points[:, 0])

    def subset(self, index) -> "Features":
        return Features(self.keypoints[index], self.descriptors[index], self.responses[index],
                        self.points[index], self.binary)


def _make_detector(kind: str, max_features: int):
    """(detector, describer) pair; ``describer`` None means the detector describes itself."""
    if kind == "SURF":
        raise InputError("feature detector SURF is patented and absent from the pip OpenCV builds; "
                         f"choose one of {', '.join(DETECTORS)}")
    if kind == "ORB":
        return cv2.ORB_create(nfeatures=max_features * 2, fastThreshold=ORB_THRESHOLD.start), None
    if kind == "SIFT":
        return cv2.SIFT_create(nfeatures=max_features * 2, contrastThreshold=SIFT_THRESHOLD.start), None
    if kind == "AKAZE":
        return cv2.xfeatures2d.AKAZE_create(threshold=0.0005), None
    if kind == "BRISK":
        return cv2.xfeatures2d.BRISK_create(thresh=20), None
    # RTAB-Map defaults: GFTT/QualityLevel 0.001, GFTT/MinDistance 7, GFTT/BlockSize 3.
    gftt = cv2.GFTTDetector_create(maxCorners=max_features, qualityLevel=0.001, minDistance=7, blockSize=3)
    if kind == "GFTT_ORB":
        return gftt, cv2.ORB_create(edgeThreshold=19, patchSize=31)
    if kind == "GFTT_BRIEF":
        return gftt, cv2.xfeatures2d.BriefDescriptorExtractor_create(32)
    raise InputError(f"unknown feature detector {kind!r}; valid: {', '.join(DETECTORS)}")


@dataclass(frozen=True)
class AdjustableThreshold:
    """A detector threshold that RGB-D SLAM v2's detector adjuster may move within bounds."""

    start: float
    floor: float
    ceiling: float
    setter: str
    integer: bool = False


# v2's DetectorAdjuster starts ORB's FAST threshold at 20 and SIFT's contrast at 0.04.
ORB_THRESHOLD = AdjustableThreshold(20, 1, 80, "setFastThreshold", integer=True)
SIFT_THRESHOLD = AdjustableThreshold(0.04, 0.0001, 0.16, "setContrastThreshold")
ADJUSTABLE = {"ORB": ORB_THRESHOLD, "SIFT": SIFT_THRESHOLD}


def _spread_over_grid(points: np.ndarray, responses: np.ndarray, shape: tuple[int, int],
                      grid: int, limit: int) -> np.ndarray:
    """Indices of at most ``limit`` keypoints, strongest first, at most limit/grid² per cell
    while other cells have room, so the features cover the whole image."""
    order = np.argsort(-responses, kind="stable")
    if grid <= 1:
        return order[:limit]
    height, width = shape
    cell = (np.minimum((points[order, 1] * grid / height).astype(int), grid - 1) * grid
            + np.minimum((points[order, 0] * grid / width).astype(int), grid - 1))
    # Rank of each keypoint within its cell, in decreasing response order.
    cell_order = np.argsort(cell, kind="stable")
    sorted_cells = cell[cell_order]
    starts = np.searchsorted(sorted_cells, sorted_cells, side="left")
    rank = np.empty(len(order), dtype=int)
    rank[cell_order] = np.arange(len(order)) - starts
    quota = max(1, limit // (grid * grid))
    chosen = order[np.argsort(rank >= quota, kind="stable")]  # in-quota first, then the rest by strength
    return chosen[:limit]


class FeatureExtractor:
    """Detect, describe and back-project keypoints of one RGB-D frame.

    With ``adjuster_iterations`` > 0 the detector threshold adapts as RGB-D SLAM v2's
    "video" dynamic adjuster does: when a frame yields fewer than ``max_features``
    keypoints the threshold is lowered (halved) and detection repeated, at most that many
    times, and when it yields more than 1.5 times as many the threshold is raised for the
    next frame. The threshold carries over from frame to frame, so faint texture (a plain
    wooden plane) still gives keypoints while rich texture is not flooded with them.
    """

    def __init__(self, kind: str, max_features: int, camera: Camera, grid: int = 1,
                 min_depth: float = 0.3, max_depth: float = 6.0, adjuster_iterations: int = 0):
        self.kind = kind
        self.max_features = max_features
        self.camera = camera
        self.grid = grid
        self.min_depth = min_depth
        self.max_depth = max_depth
        self.detector, self.describer = _make_detector(kind, max_features)
        self.binary = kind in BINARY_DESCRIPTORS
        self.adjustable = ADJUSTABLE.get(kind) if adjuster_iterations > 0 else None
        self.adjuster_iterations = adjuster_iterations
        self.threshold = self.adjustable.start if self.adjustable else None

    def _set_threshold(self, value: float) -> None:
        value = float(np.clip(value, self.adjustable.floor, self.adjustable.ceiling))
        self.threshold = int(round(value)) if self.adjustable.integer else value
        getattr(self.detector, self.adjustable.setter)(self.threshold)

    def _detect(self, gray: np.ndarray) -> list:
        keypoints = self.detector.detect(gray, None)
        if self.adjustable is None:
            return keypoints
        for _ in range(self.adjuster_iterations):
            if len(keypoints) >= self.max_features or self.threshold <= self.adjustable.floor:
                break
            self._set_threshold(self.threshold / 2)
            keypoints = self.detector.detect(gray, None)
        if len(keypoints) > 1.5 * self.max_features:
            self._set_threshold(self.threshold * 1.5)
        return keypoints

    def extract(self, rgb: np.ndarray, depth: np.ndarray) -> Features:
        gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        keypoints = self._detect(gray)
        if keypoints:
            xy = np.array([k.pt for k in keypoints], dtype=np.float32)
            strength = np.array([k.response for k in keypoints], dtype=np.float32)
            keep = _spread_over_grid(xy, strength, gray.shape, self.grid, self.max_features)
            keypoints = [keypoints[i] for i in keep]
        describer = self.describer or self.detector
        keypoints, descriptors = describer.compute(gray, keypoints) if keypoints else ((), None)
        if descriptors is None or not len(keypoints):
            width = 128 if not self.binary else 32
            return Features(np.zeros((0, 2), np.float32), np.zeros((0, width), np.float32 if not self.binary else np.uint8),
                            np.zeros(0, np.float32), np.zeros((0, 3)), self.binary)
        xy = np.array([k.pt for k in keypoints], dtype=np.float32)
        responses = np.array([k.response for k in keypoints], dtype=np.float32)
        return Features(xy, descriptors, responses, self.backproject(xy, depth), self.binary)

    def backproject(self, xy: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """3D points of keypoints, NaN where the depth at the rounded pixel is unusable.

        TUM's freiburg1/2 images are not rectified and their depth is registered to the
        distorted colour image, so the depth is read at the keypoint itself and the ray is
        taken through the undistorted pixel.
        """
        cols = np.clip(np.rint(xy[:, 0]).astype(int), 0, depth.shape[1] - 1)
        rows = np.clip(np.rint(xy[:, 1]).astype(int), 0, depth.shape[0] - 1)
        z = depth[rows, cols].astype(np.float64)
        pixels = xy.astype(np.float64)
        if any(self.camera.distortion):
            pixels = cv2.undistortPoints(pixels.reshape(-1, 1, 2), self.camera.K, np.asarray(self.camera.distortion),
                                         P=self.camera.K).reshape(-1, 2)
        points = self.camera.backproject(pixels, z)
        points[(z < self.min_depth) | (z > self.max_depth)] = np.nan
        return points


def match_descriptors(query: np.ndarray, train: np.ndarray, binary: bool, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-neighbour matches that pass Lowe's ratio test (best < ratio * second best).

    Returns index arrays into ``query`` and ``train``; a query whose two nearest neighbours
    are too alike is dropped, as is a second query claiming an already matched train item.
    """
    query_index, train_index, _ = match_with_ratios(query, train, binary, ratio)
    return query_index, train_index


def match_with_ratios(query: np.ndarray, train: np.ndarray, binary: bool,
                      ratio: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`match_descriptors` with each match's nearest / second-nearest distance ratio."""
    if len(query) == 0 or len(train) < 2:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    # batchDistance gives the two nearest neighbours as arrays (knnMatch's exact results,
    # without a Python object per match) and releases the GIL while it searches.
    distance, nearest = cv2.batchDistance(query, train, -1, normType=cv2.NORM_HAMMING if binary else cv2.NORM_L2, K=2)
    q = np.flatnonzero(distance[:, 0] < ratio * distance[:, 1])
    t, d = nearest[q, 0].astype(int), distance[q, 0]
    best_first = np.argsort(d, kind="stable")
    _, unique = np.unique(t[best_first], return_index=True)
    keep = np.sort(best_first[unique])
    return q[keep], t[keep], distance[q[keep], 0] / distance[q[keep], 1]
