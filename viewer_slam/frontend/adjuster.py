"""RGB-D SLAM v2's adjusted grid detector (``feature_adjuster.cpp``, ``features.cpp``).

The image is split into NxN cells (overlapping by ORB's 31-pixel border so that no
keypoint is lost at the inner edges), each with a detector of its own whose threshold
carries over from frame to frame (``VideoGridAdaptedFeatureDetector``). A cell that finds
fewer than its share of ``max_keypoints`` lowers its threshold by 0.7 and detects again,
at most ``adjuster_max_iterations`` times while the threshold stays within bounds; one that
finds more than 1.5 times its share raises it by 1.3 for the next frame
(``VideoDynamicAdaptedFeatureDetector`` over ``DetectorAdjuster``). Each cell keeps its
strongest keypoints, up to its share of 1.5 * ``max_keypoints``. As in v2, the cells are
detected in parallel on the process's worker threads (OpenCV releases the GIL); each has a
detector of its own.
"""

from dataclasses import dataclass

import cv2
import numpy as np

from .workers import workers

CELL_OVERLAP_PX = 31
TOO_FEW_FACTOR = 0.7
TOO_MANY_FACTOR = 1.3


@dataclass(frozen=True)
class AdjustableThreshold:
    """A detector threshold (``DetectorAdjuster``'s initial value and bounds) and how to set it."""

    start: float
    floor: float
    ceiling: float
    setter: str
    integer: bool = False


# features.cpp: DetectorAdjuster("AORB", 20) and ("SIFT", 0.04, 0.0001); bounds default to 2 and 10000.
ORB_THRESHOLD = AdjustableThreshold(20, 2, 10000, "setFastThreshold", integer=True)
SIFT_THRESHOLD = AdjustableThreshold(0.04, 0.0001, 10000, "setContrastThreshold")
ADJUSTABLE = {"ORB": ORB_THRESHOLD, "SIFT": SIFT_THRESHOLD}


def _cell_detector(kind: str):
    # v2's AORB: ORB with 10000 features, FAST threshold adjusted; SIFT with no feature limit.
    return cv2.ORB.create(nfeatures=10000) if kind == "ORB" else cv2.SIFT.create(nfeatures=0)


class AdjustedDetector:
    """One detector whose threshold adapts to keep its keypoints within ``[low, high]``."""

    def __init__(self, kind: str, low: int, high: int, iterations: int):
        self.bounds = ADJUSTABLE[kind]
        self.detector = _cell_detector(kind)
        self.low, self.high, self.iterations = low, high, iterations
        self.threshold = float(self.bounds.start)

    def _good(self) -> bool:
        return self.bounds.floor < self.threshold < self.bounds.ceiling

    def _scale(self, factor: float) -> None:
        self.threshold = float(np.clip(self.threshold * factor, self.bounds.floor, self.bounds.ceiling))

    def detect(self, gray: np.ndarray) -> list:
        remaining = self.iterations
        while True:
            value = int(self.threshold) if self.bounds.integer else self.threshold
            getattr(self.detector, self.bounds.setter)(value)
            keypoints = self.detector.detect(gray, None)
            if len(keypoints) < self.low:
                self._scale(TOO_FEW_FACTOR)
            else:
                if len(keypoints) > self.high:
                    self._scale(TOO_MANY_FACTOR)
                return keypoints
            remaining -= 1
            if remaining <= 0 or not self._good():
                return keypoints


def cell_ranges(length: int, cells: int) -> list[tuple[int, int]]:
    """Each cell's [start, end) along one image axis, widened by CELL_OVERLAP_PX within the image."""
    return [
        (max(i * length // cells - CELL_OVERLAP_PX, 0), min(length, (i + 1) * length // cells + CELL_OVERLAP_PX))
        for i in range(cells)
    ]


class GridDetector:
    """v2's gridded adjusted detector for ``max_keypoints`` over ``grid`` x ``grid`` cells."""

    def __init__(self, kind: str, max_keypoints: int, grid: int, iterations: int):
        cells = grid * grid
        high = int(max_keypoints * 1.5)
        self.grid = grid
        self.per_cell = high // cells
        self.detectors = [
            AdjustedDetector(kind, round(max_keypoints / cells), round(high / cells), iterations) for _ in range(cells)
        ]

    def _detect_cell(self, gray: np.ndarray, cell: int, rows: tuple[int, int], cols: tuple[int, int]) -> list:
        """The cell's strongest keypoints, in image coordinates."""
        (top, bottom), (left, right) = rows, cols
        found = self.detectors[cell].detect(np.ascontiguousarray(gray[top:bottom, left:right]))
        # The order of a stable sort by -|response|, by NumPy rather than a Python key per keypoint.
        strongest = np.argsort(-np.abs([k.response for k in found]), kind="stable")[: self.per_cell]
        found = [found[i] for i in strongest]
        for keypoint in found:
            keypoint.pt = (keypoint.pt[0] + left, keypoint.pt[1] + top)
        return found

    def detect(self, gray: np.ndarray) -> list:
        """Keypoints of every cell, each cell's strongest first."""
        rows, cols = cell_ranges(gray.shape[0], self.grid), cell_ranges(gray.shape[1], self.grid)
        cells = [(i * self.grid + j, row, col) for i, row in enumerate(rows) for j, col in enumerate(cols)]
        found = workers().map(lambda cell: self._detect_cell(gray, *cell), cells)
        return [keypoint for cell in found for keypoint in cell]
