"""A Kinect-like RGB-D sensor applied to ideal renders.

Depth follows the structured-light geometry: the sensor measures disparity, so noise and
the 1/8-pixel disparity quantisation grow with the square of the distance (about 1.5 mm
at 1 m, 2.5 cm steps at 3 m, Khoshelham & Elberink 2012); nothing is measured closer than
0.5 m or beyond 4.5 m, at grazing angles, or on the far side of depth edges. Colour gets
lens softness, vignetting, optional motion blur along the per-pixel image motion, and
signal-dependent noise.
"""

import functools
from dataclasses import dataclass

import cv2
import numpy as np

from ...geometry.camera import Camera
from ...geometry.se3 import invert
from .render import rotate

# Baseline (7.5 cm) times focal length (580 px) of the Kinect's infrared pair, in metre-pixels.
BASELINE_FOCAL = 0.075 * 580.0


@dataclass(frozen=True)
class KinectModel:
    min_range: float = 0.5
    max_range: float = 4.5
    disparity_noise: float = 0.05      # px, per pixel
    disparity_drift: float = 0.03      # px, spatially smooth component
    disparity_step: float = 1.0 / 8.0  # px
    grazing_cos: float = 0.08          # below: never measured; up to twice this: sometimes
    edge_jump: float = 0.04            # relative depth jump that marks a depth edge
    dropout: float = 0.003             # isolated missing pixels
    colour_noise: float = 1.6          # grey levels, plus shot noise below
    shot_noise: float = 0.05           # variance per grey level
    vignetting: float = 0.25           # brightness lost in the corners

    def depth(self, rng: np.random.Generator, ideal: np.ndarray, cos_incidence: np.ndarray) -> np.ndarray:
        """Measured depth (float32 metres, 0 = no measurement) from the ideal depth."""
        h, w = ideal.shape
        valid = (ideal >= self.min_range) & (ideal <= self.max_range)
        disparity = BASELINE_FOCAL / np.where(valid, ideal, np.float32(1.0))
        drift = cv2.resize(rng.standard_normal((h // 16 + 1, w // 16 + 1), np.float32), (w, h),
                           interpolation=cv2.INTER_LINEAR)
        noise = self.disparity_noise * rng.standard_normal((h, w), np.float32) + self.disparity_drift * drift
        disparity = np.round((disparity + noise) / self.disparity_step) * self.disparity_step
        valid &= disparity > 0
        grazing = cos_incidence < self.grazing_cos * (1.0 + rng.random((h, w), np.float32))
        valid &= ~grazing & ~self._edge_shadow(rng, ideal) & (rng.random((h, w), np.float32) >= self.dropout)
        return np.where(valid, BASELINE_FOCAL / np.where(valid, disparity, 1.0), 0.0).astype(np.float32)

    def _edge_shadow(self, rng, ideal: np.ndarray) -> np.ndarray:
        """Pixels lost behind depth edges: the far side of each jump, in a ragged 1-2 pixel band.

        A jump is a step in inverse depth that neither neighbouring step predicts; inverse
        depth is linear across a plane, so slanted planes (a floor far ahead) are no edges.
        """
        inverse = np.where(ideal > 0, 1.0 / np.maximum(ideal, 1e-6), 0.0)
        far = np.zeros(ideal.shape, bool)
        for axis in (0, 1):
            x, marks = np.moveaxis(inverse, axis, 0), np.moveaxis(far, axis, 0)
            step = x[1:] - x[:-1]
            padded = np.pad(step, [(1, 1)] + [(0, 0)] * (step.ndim - 1), mode="edge")
            surprise = np.minimum(np.abs(step - padded[:-2]), np.abs(step - padded[2:]))
            edge = surprise > self.edge_jump * np.maximum(x[1:], x[:-1])
            marks[1:] |= edge & (x[1:] < x[:-1])
            marks[:-1] |= edge & (x[:-1] < x[1:])
        # Widen the shadow by a pixel, randomly, but only over surfaces as far as the shadowed ones.
        reach = cv2.dilate(np.where(far, inverse, 0.0).astype(np.float32), np.ones((3, 3), np.uint8))
        band = (reach > 0) & (inverse <= reach * (1 + self.edge_jump))
        return far | (band & (rng.random(far.shape, np.float32) < 0.6))

    def colour(self, rng: np.random.Generator, ideal: np.ndarray) -> np.ndarray:
        """Measured colour (uint8 RGB) from the ideal float image (already motion-blurred)."""
        h, w = ideal.shape[:2]
        softness = 0.5 * w / 640.0
        image = cv2.GaussianBlur(ideal, (0, 0), softness) if softness >= 0.3 else ideal
        image = image * _vignetting(h, w, self.vignetting)[..., None]
        sigma = np.sqrt(self.colour_noise ** 2 + self.shot_noise * np.maximum(image, 0.0))
        image = image + sigma * rng.standard_normal(image.shape, np.float32)
        return np.clip(np.rint(image), 0, 255).astype(np.uint8)


@functools.lru_cache(maxsize=4)
def _vignetting(h: int, w: int, strength: float) -> np.ndarray:
    rows, cols = np.indices((h, w), dtype=np.float32)
    r2 = ((cols - w / 2) / (w / 2)) ** 2 + ((rows - h / 2) / (h / 2)) ** 2
    return 1.0 - strength * r2 / 2.0


@functools.lru_cache(maxsize=4)
def _pixel_grid(h: int, w: int) -> np.ndarray:
    grid = np.indices((h, w), dtype=np.float32)
    grid.flags.writeable = False
    return grid


def motion_blur(image: np.ndarray, points: np.ndarray, hit: np.ndarray, camera: Camera,
                pose_start: np.ndarray, pose_end: np.ndarray, samples: int = 4) -> np.ndarray:
    """Average the image along each pixel's motion during the exposure.

    ``points`` are the world points seen at mid-exposure; their projections at the start
    and the end of the exposure give each pixel's streak (computed on every fourth pixel:
    image motion is smooth), sampled at ``samples`` positions.
    """
    h, w = hit.shape
    coarse = points[::4, ::4]
    ends = []
    for pose in (pose_start, pose_end):
        to_camera = invert(pose)
        p = rotate(coarse, to_camera[:3, :3]) + to_camera[:3, 3]
        z = np.maximum(p[..., 2], 1e-3)
        ends.append(np.stack([camera.fx * p[..., 0] / z, camera.fy * p[..., 1] / z], -1))
    flow = np.where(hit[::4, ::4, None], ends[1] - ends[0], 0.0).astype(np.float32)
    if np.abs(flow).max() < 0.5:
        return image
    flow = cv2.resize(flow, (w, h), interpolation=cv2.INTER_LINEAR)
    rows, cols = _pixel_grid(h, w)
    blurred = np.zeros_like(image)
    for s in np.linspace(-0.5, 0.5, samples, dtype=np.float32):
        blurred += cv2.remap(image, cols + s * flow[..., 0], rows + s * flow[..., 1], cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
    return blurred / samples
