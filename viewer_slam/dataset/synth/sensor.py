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
from scipy.special import ndtri

from ...geometry.camera import Camera
from ...geometry.se3 import invert
from .render import rotate

# Baseline (7.5 cm) times focal length (580 px) of the Kinect's infrared pair, in metre-pixels.
BASELINE_FOCAL = 0.075 * 580.0


@dataclass(frozen=True)
class KinectModel:
    min_range: float = 0.5
    max_range: float = 4.5
    disparity_noise: float = 0.05  # px, per pixel
    disparity_drift: float = 0.03  # px, spatially smooth component
    disparity_step: float = 1.0 / 8.0  # px
    grazing_cos: float = 0.08  # below: never measured; up to twice this: sometimes
    edge_jump: float = 0.04  # relative depth jump that marks a depth edge
    dropout: float = 0.003  # isolated missing pixels
    colour_noise: float = 1.6  # grey levels, plus shot noise below
    shot_noise: float = 0.05  # variance per grey level
    vignetting: float = 0.25  # brightness lost in the corners

    def depth(self, rng: np.random.Generator, ideal: np.ndarray, cos_incidence: np.ndarray) -> np.ndarray:
        """Measured depth (float32 metres, 0 = no measurement) from the ideal depth."""
        h, w = ideal.shape
        valid = (ideal >= self.min_range) & (ideal <= self.max_range)
        disparity = BASELINE_FOCAL / np.where(valid, ideal, np.float32(1.0))
        drift = cv2.resize(gaussian_noise(rng, (h // 16 + 1, w // 16 + 1)), (w, h), interpolation=cv2.INTER_LINEAR)
        disparity += np.float32(self.disparity_noise) * gaussian_noise(rng, (h, w))
        disparity += np.float32(self.disparity_drift) * drift
        steps = np.rint(disparity * np.float32(1.0 / self.disparity_step))  # quantised, in whole steps
        valid &= steps > 0
        lost = valid.ravel()  # a view: clearing it clears valid
        # Random draws only where they can matter: near-grazing pixels, and the few dropouts.
        maybe = np.flatnonzero(cos_incidence.ravel() < 2 * self.grazing_cos)
        chance = self.grazing_cos * (1.0 + rng.random(len(maybe), np.float32))
        lost[maybe[cos_incidence.ravel()[maybe] < chance]] = False
        lost[rng.integers(0, h * w, rng.binomial(h * w, self.dropout))] = False
        valid &= ~self._edge_shadow(rng, ideal)
        return np.where(valid, np.float32(BASELINE_FOCAL / self.disparity_step) / np.maximum(steps, 1), np.float32(0.0))

    def _edge_shadow(self, rng, ideal: np.ndarray) -> np.ndarray:
        """Pixels lost behind depth edges: the far side of each jump, in a ragged 1-2 pixel band.

        A jump is a step in inverse depth that neither neighbouring step predicts; inverse
        depth is linear across a plane, so slanted planes (a floor far ahead) are no edges.
        """
        inverse = np.where(ideal > 0, 1.0 / np.maximum(ideal, np.float32(1e-6)), np.float32(0.0))
        # Columns as rows of the transposed copy: the same sums on contiguous memory.
        far = self._far_rows(inverse) | self._far_rows(np.ascontiguousarray(inverse.T)).T
        # Widen the shadow by a pixel, randomly, but only over surfaces as far as the shadowed ones.
        reach = cv2.dilate(np.where(far, inverse, np.float32(0.0)), np.ones((3, 3), np.uint8))
        band = np.flatnonzero(((reach > 0) & (inverse <= reach * np.float32(1 + self.edge_jump)) & ~far).ravel())
        far.ravel()[band[rng.random(len(band), np.float32) < 0.6]] = True
        return far

    def _far_rows(self, x: np.ndarray) -> np.ndarray:
        """The far side of the jumps of inverse depth ``x`` between consecutive rows."""
        step = x[1:] - x[:-1]
        padded = np.concatenate([step[:1], step, step[-1:]])
        surprise = np.minimum(np.abs(step - padded[:-2]), np.abs(step - padded[2:]))
        edge = surprise > np.float32(self.edge_jump) * np.maximum(x[1:], x[:-1])
        far = np.zeros(x.shape, bool)
        far[1:] = edge & (step < 0)
        far[:-1] |= edge & (step > 0)
        return far

    def colour(self, rng: np.random.Generator, ideal: np.ndarray) -> np.ndarray:
        """Measured colour (uint8 RGB) from the ideal uint8 image (already motion-blurred)."""
        h, w = ideal.shape[:2]
        softness = 0.5 * w / 640.0
        image = cv2.GaussianBlur(ideal, (0, 0), softness) if softness >= 0.3 else ideal
        signal = cv2.multiply(image, _vignetting(h, w, self.vignetting), dtype=cv2.CV_32F)
        # In place: each full-size temporary costs as much as the arithmetic.
        noise = gaussian_noise(rng, image.shape)
        sigma = signal * np.float32(self.shot_noise)
        sigma += np.float32(self.colour_noise**2)
        noise *= np.sqrt(sigma, out=sigma)
        noise += signal
        return np.clip(np.rint(noise, out=noise), 0, 255, out=noise).astype(np.uint8)


@functools.lru_cache(maxsize=1)
def _normal_quantiles() -> np.ndarray:
    """The standard normal's quantiles at the midpoints of 2^16 equal steps of probability."""
    table = ndtri((np.arange(1 << 16) + 0.5) / (1 << 16)).astype(np.float32)
    table.flags.writeable = False
    return table


def gaussian_noise(rng: np.random.Generator, shape) -> np.ndarray:
    """Standard normal float32 noise from 16 random bits per value, through the quantile table.

    Four times faster than ``rng.standard_normal``; the tails stop at 4.2 sigma, where a
    pixel's noise is lost in rounding anyway.
    """
    bits = np.frombuffer(rng.bytes(2 * int(np.prod(shape))), "<u2").reshape(shape)
    return np.take(_normal_quantiles(), bits)


@functools.lru_cache(maxsize=4)
def _vignetting(h: int, w: int, strength: float) -> np.ndarray:
    """Brightness factor per pixel, repeated for the three channels (float32 ``(H, W, 3)``)."""
    rows, cols = np.indices((h, w), dtype=np.float32)
    r2 = ((cols - w / 2) / (w / 2)) ** 2 + ((rows - h / 2) / (h / 2)) ** 2
    factor = np.repeat((1.0 - strength * r2 / 2.0)[..., None], 3, axis=-1)
    factor.flags.writeable = False
    return factor


@functools.lru_cache(maxsize=4)
def _pixel_grid(h: int, w: int) -> np.ndarray:
    grid = np.indices((h, w), dtype=np.float32)
    grid.flags.writeable = False
    return grid


def motion_blur(
    image: np.ndarray,
    grid_points: np.ndarray,
    grid_hit: np.ndarray,
    camera: Camera,
    pose_start: np.ndarray,
    pose_end: np.ndarray,
    samples: int = 4,
) -> np.ndarray:
    """Average the image along each pixel's motion during the exposure.

    ``grid_points`` are the world points seen at mid-exposure on the renderer's coarse
    grid (every fourth pixel: image motion is smooth); their projections at the start and
    the end of the exposure give each pixel's streak, sampled at ``samples`` positions.
    """
    h, w = image.shape[:2]
    ends = []
    for pose in (pose_start, pose_end):
        to_camera = invert(pose)
        p = rotate(grid_points, to_camera[:3, :3].astype(np.float32)) + to_camera[:3, 3].astype(np.float32)
        z = np.maximum(p[..., 2], np.float32(1e-3))
        ends.append(np.stack([np.float32(camera.fx) * p[..., 0] / z, np.float32(camera.fy) * p[..., 1] / z], -1))
    flow = np.where(grid_hit[..., None], ends[1] - ends[0], np.float32(0.0))
    if np.abs(flow).max() < 0.5:
        return image
    flow_x, flow_y = cv2.split(cv2.resize(flow, (w, h), interpolation=cv2.INTER_LINEAR))  # contiguous planes
    rows, cols = _pixel_grid(h, w)
    rgba = cv2.cvtColor(image, cv2.COLOR_RGB2RGBA)  # OpenCV's remap is vectorised for four channels
    total = np.zeros(rgba.shape, np.uint16)
    map_x, map_y = np.empty_like(flow_x), np.empty_like(flow_y)
    for s in np.linspace(-0.5, 0.5, samples, dtype=np.float32):
        np.add(cols, np.multiply(flow_x, s, out=map_x), out=map_x)
        np.add(rows, np.multiply(flow_y, s, out=map_y), out=map_y)
        cv2.add(
            total,
            cv2.remap(rgba, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE),
            dst=total,
            dtype=cv2.CV_16U,
        )
    return cv2.cvtColor(cv2.convertScaleAbs(total, alpha=1.0 / samples), cv2.COLOR_RGBA2RGB)
