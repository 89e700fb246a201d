"""Keypoint detection, description, back-projection to 3D and ratio-test matching.

One :class:`FeatureExtractor` serves both pipelines: RGB-D SLAM's detectors (ORB spread
with a detector grid, SIFT, and what OpenCV offers cheaply) and RTAB-Map's GFTT corners
with ORB or BRIEF descriptors (Kp/DetectorStrategy 8 and 6).
"""

import typing
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from ..compiled import jit
from ..errors import InputError
from ..geometry.camera import Camera
from .adjuster import ADJUSTABLE, ORB_THRESHOLD, SIFT_THRESHOLD, GridDetector

BINARY_DESCRIPTORS = {"ORB", "BRISK", "AKAZE", "GFTT_ORB", "GFTT_BRIEF"}
Detector = Literal["ORB", "SIFT", "AKAZE", "BRISK", "GFTT_ORB", "GFTT_BRIEF"]
DETECTORS: tuple[str, ...] = typing.get_args(Detector)
# RTAB-Map's depth smoothing (util2d::getDepth): the keypoint's depth averaged over its 3x3
# neighbourhood with weights 4 (centre), 2 (edge) and 1 (corner), counting only the
# neighbours within SMOOTHING_DEPTH_ERROR_RATIO of the centre's depth (its depthErrorRatio:
# 2 cm at 1 m, 8 cm at 4 m, so that far walls, noisier, are smoothed over as many neighbours).
SMOOTHING_OFFSETS = np.array([(row, col) for row in (-1, 0, 1) for col in (-1, 0, 1)])
SMOOTHING_WEIGHTS = np.array([1.0, 2.0, 1.0, 2.0, 4.0, 2.0, 1.0, 2.0, 1.0])
SMOOTHING_DEPTH_ERROR_RATIO = 0.02


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
        return Features(
            self.keypoints[index], self.descriptors[index], self.responses[index], self.points[index], self.binary
        )


def _make_detector(kind: str, max_features: int):
    """(detector, describer) pair; ``describer`` None means the detector describes itself."""
    if kind == "SURF":
        raise InputError(
            "feature detector SURF is patented and absent from the pip OpenCV builds; "
            f"choose one of {', '.join(DETECTORS)}"
        )
    if kind == "ORB":
        return cv2.ORB.create(nfeatures=max_features * 2, fastThreshold=int(ORB_THRESHOLD.start)), None
    if kind == "SIFT":
        return cv2.SIFT.create(nfeatures=max_features * 2, contrastThreshold=SIFT_THRESHOLD.start), None
    if kind == "AKAZE":
        return cv2.AKAZE.create(threshold=0.0005), None
    if kind == "BRISK":
        return cv2.BRISK.create(thresh=20), None
    # RTAB-Map defaults: GFTT/QualityLevel 0.001, GFTT/MinDistance 7, GFTT/BlockSize 3.
    gftt = cv2.GFTTDetector.create(maxCorners=max_features, qualityLevel=0.001, minDistance=7, blockSize=3)
    if kind == "GFTT_ORB":
        return gftt, cv2.ORB.create(edgeThreshold=19, patchSize=31)
    if kind == "GFTT_BRIEF":
        return gftt, cv2.xfeatures2d.BriefDescriptorExtractor.create(32)
    raise InputError(f"unknown feature detector {kind!r}; valid: {', '.join(DETECTORS)}")


def _positions(keypoints: list) -> np.ndarray:
    """The keypoints' pixel positions, float32 (N, 2) as they hold them, read in one OpenCV call."""
    return np.asarray(cv2.KeyPoint.convert(keypoints), np.float32).reshape(-1, 2)


def _strongest(responses: np.ndarray, limit: int) -> np.ndarray:
    """Indices of the ``limit`` strongest keypoints, strongest first."""
    return np.argsort(-responses, kind="stable")[:limit]


class FeatureExtractor:
    """Detect, describe and back-project keypoints of one RGB-D frame.

    With ``adjuster_iterations`` > 0 (ORB, SIFT) detection is RGB-D SLAM v2's adjusted grid
    detector (:mod:`.adjuster`): ``grid`` x ``grid`` cells with thresholds of their own; then,
    as v2's ``Node`` constructor, keypoints without depth are dropped and the ``max_features``
    strongest of the rest described. Otherwise one detector gives the ``max_features``
    strongest keypoints.

    Two options reproduce RTAB-Map's extraction: ``depth_mask`` detects only where the depth
    is within range (Vis/DepthAsMask), ``depth_smoothing`` reads a keypoint's depth as
    ``util3d::generateKeypoints3DDepth`` does (:func:`smoothed_depth`).
    """

    def __init__(
        self,
        kind: str,
        max_features: int,
        camera: Camera,
        grid: int = 1,
        min_depth: float = 0.3,
        max_depth: float = 6.0,
        adjuster_iterations: int = 0,
        depth_mask: bool = False,
        depth_smoothing: bool = False,
    ):
        self.kind = kind
        self.depth_mask = depth_mask
        self.depth_smoothing = depth_smoothing
        self.max_features = max_features
        self.camera = camera
        self.min_depth = min_depth
        self.max_depth = max_depth
        self.detector, self.describer = _make_detector(kind, max_features)
        self.binary = kind in BINARY_DESCRIPTORS
        self.adjusted = (
            GridDetector(kind, max_features, grid, adjuster_iterations)
            if adjuster_iterations > 0 and kind in ADJUSTABLE
            else None
        )

    def _detect(self, gray: np.ndarray, depth: np.ndarray) -> list:
        if self.adjusted is not None:
            keypoints = self.adjusted.detect(gray)
            if keypoints:
                with_depth = ~np.isnan(self.backproject(_positions(keypoints), depth)[:, 0])
                keypoints = [k for k, keep in zip(keypoints, with_depth) if keep]
        else:
            keypoints = self.detector.detect(gray, self._in_range(depth) if self.depth_mask else None)
        if not keypoints:
            return keypoints
        return [keypoints[i] for i in _strongest(np.array([k.response for k in keypoints]), self.max_features)]

    def extract(self, rgb: np.ndarray, depth: np.ndarray, grey: np.ndarray | None = None) -> Features:
        """The features of one RGB-D frame; ``grey``, when given, is ``rgb`` already in grey
        levels (:attr:`~viewer_slam.dataset.frame.Frame.grey`), not converted again."""
        gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY) if grey is None else grey
        keypoints = self._detect(gray, depth)
        describer = self.describer or self.detector
        keypoints, descriptors = describer.compute(gray, keypoints) if keypoints else ([], None)
        if descriptors is None or not len(keypoints):
            width = 128 if not self.binary else 32
            return Features(
                np.zeros((0, 2), np.float32),
                np.zeros((0, width), np.float32 if not self.binary else np.uint8),
                np.zeros(0, np.float32),
                np.zeros((0, 3)),
                self.binary,
            )
        xy = _positions(keypoints)
        responses = np.array([k.response for k in keypoints], dtype=np.float32)
        return Features(xy, descriptors, responses, self.backproject(xy, depth), self.binary)

    def _in_range(self, depth: np.ndarray) -> np.ndarray:
        """Detection mask (255 where min_depth < depth <= max_depth), as Feature2D::generateKeypoints."""
        return ((depth > self.min_depth) & (depth <= self.max_depth)).astype(np.uint8) * 255

    def backproject(self, xy: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """3D points of keypoints, NaN where the depth at the rounded pixel is unusable.

        TUM's freiburg1/2 images are not rectified and their depth is registered to the
        distorted colour image, so the depth is read at the keypoint itself and the ray is
        taken through the undistorted pixel.
        """
        cols = np.clip(np.rint(xy[:, 0]).astype(int), 0, depth.shape[1] - 1)
        rows = np.clip(np.rint(xy[:, 1]).astype(int), 0, depth.shape[0] - 1)
        z = (smoothed_depth(depth, rows, cols) if self.depth_smoothing else depth[rows, cols]).astype(np.float64)
        pixels: np.ndarray = xy.astype(np.float64)
        if any(self.camera.distortion) and len(pixels):  # OpenCV 4 returns None for no points
            pixels = cv2.undistortPoints(
                pixels.reshape(-1, 1, 2), self.camera.K, np.asarray(self.camera.distortion), P=self.camera.K
            ).reshape(-1, 2)
        points = self.camera.backproject(pixels, z)
        points[(z < self.min_depth) | (z > self.max_depth)] = np.nan
        return points


@jit
def _smoothed_depth(depth, rows, cols):
    """:func:`smoothed_depth` a keypoint at a time, operation for operation as NumPy computes
    it on the (N, 9) window: each sum over a row of nine is NumPy's pairwise one (eight partial
    sums added in pairs, then the ninth term), so the result is the same to the bit."""
    height, width = depth.shape
    smoothed = np.zeros(rows.shape[0])
    terms, weights = np.empty(9), np.empty(9)
    for i in range(rows.shape[0]):
        centre = np.float64(depth[rows[i], cols[i]])
        for k in range(9):
            row, col = rows[i] + SMOOTHING_OFFSETS[k, 0], cols[i] + SMOOTHING_OFFSETS[k, 1]
            value = np.float64(depth[min(max(row, 0), height - 1), min(max(col, 0), width - 1)])
            counted = (
                0 <= row < height
                and 0 <= col < width
                and value > 0
                and np.isfinite(value)
                and abs(value - centre) < SMOOTHING_DEPTH_ERROR_RATIO * centre
            )
            weights[k] = SMOOTHING_WEIGHTS[k] * (1.0 if counted else 0.0)
            terms[k] = weights[k] * (value if counted else 0.0)
        if centre > 0:
            smoothed[i] = _sum_of_nine(terms) / max(_sum_of_nine(weights), 1e-12)
    return smoothed


@jit
def _sum_of_nine(values):
    """NumPy's pairwise sum of nine values."""
    return (
        ((values[0] + values[1]) + (values[2] + values[3])) + ((values[4] + values[5]) + (values[6] + values[7]))
    ) + values[8]


def smoothed_depth(depth: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Depth at pixels (rows, cols) smoothed as RTAB-Map's ``util2d::getDepth``: a weighted
    mean over the 3x3 neighbourhood (:data:`SMOOTHING_WEIGHTS`) of the measured depths closer
    to the centre's than :data:`SMOOTHING_DEPTH_ERROR_RATIO` times it; 0 where the centre has none."""
    return _smoothed_depth(depth, np.asarray(rows, np.int64), np.asarray(cols, np.int64))


def match_descriptors(
    query: np.ndarray, train: np.ndarray, binary: bool, ratio: float
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-neighbour matches that pass Lowe's ratio test (best < ratio * second best).

    Returns index arrays into ``query`` and ``train``; a query whose two nearest neighbours
    are too alike is dropped, as is a second query claiming an already matched train item.
    """
    query_index, train_index, _ = match_with_ratios(query, train, binary, ratio)
    return query_index, train_index


def match_with_ratios(
    query: np.ndarray, train: np.ndarray, binary: bool, ratio: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`match_descriptors` with each match's nearest / second-nearest distance ratio."""
    q, t, d, ratios = nearest_passing_ratio(query, train, binary, ratio)
    best_first = np.argsort(d, kind="stable")
    _, unique = np.unique(t[best_first], return_index=True)
    keep = np.sort(best_first[unique])
    return q[keep], t[keep], ratios[keep]


def nearest_passing_ratio(
    query: np.ndarray, train: np.ndarray, binary: bool, ratio: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each query's nearest train descriptor where it passes the ratio test against the second
    nearest: query indices (ascending), train indices (a train descriptor may be the nearest
    of several queries), the nearest distances and the distance ratios."""
    if len(query) == 0 or len(train) < 2:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0), np.zeros(0)
    # batchDistance gives the two nearest neighbours as arrays (knnMatch's exact results,
    # without a Python object per match) and releases the GIL while it searches.
    distance, nearest = cv2.batchDistance(query, train, -1, normType=cv2.NORM_HAMMING if binary else cv2.NORM_L2, K=2)
    q = np.flatnonzero(distance[:, 0] < ratio * distance[:, 1])
    return q, nearest[q, 0].astype(int), distance[q, 0], distance[q, 0] / distance[q, 1]
