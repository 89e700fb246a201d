"""Camera motion and sensor timing.

A :class:`Path` is the camera pose as a smooth function of time, interpolated (PCHIP:
continuous velocity, no overshoot) through keyframes of position and viewing angles
(yaw about the world's vertical, pitch downwards, roll), plus an optional hand tremor.
:func:`sensor_timing` gives TUM-like stamps: colour at ~30 Hz with jitter, depth a few
milliseconds off, ground truth at 100 Hz spanning both.
"""

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator

from ...geometry.se3 import make_pose, pose_from_tq, pose_to_tq

CAMERA_RATE = 30.0
GROUNDTRUTH_RATE = 100.0
START_TIME = 1311868164.0  # as in TUM's freiburg2 recordings


def rotation_from_angles(yaw, pitch, roll) -> np.ndarray:
    """Camera rotations ``(N, 3, 3)``: optical axis at ``yaw`` and ``pitch`` (down positive), then rolled.

    Columns are the camera's x (right), y (down) and z (forward) axes in the z-up world.
    """
    yaw, pitch, roll = (np.asarray(a, np.float64) for a in (yaw, pitch, roll))
    forward = np.stack([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), -np.sin(pitch)], -1)
    right = np.stack([np.sin(yaw), -np.cos(yaw), np.zeros_like(yaw)], -1)
    down = np.cross(forward, right)
    c, s = np.cos(roll)[..., None], np.sin(roll)[..., None]
    return np.stack([c * right + s * down, c * down - s * right, forward], axis=-1)


def look_angles(position, target) -> tuple[float, float]:
    """Yaw and pitch that point the optical axis from ``position`` at ``target``."""
    d = np.asarray(target, np.float64) - np.asarray(position, np.float64)
    return float(np.arctan2(d[1], d[0])), float(np.arctan2(-d[2], np.hypot(d[0], d[1])))


class Tremor:
    """Hand tremor and small wobble: a few random sinusoids (0.3 to 4 Hz) per axis."""

    def __init__(self, rng: np.random.Generator, position: float, angle: float, components: int = 5):
        self.frequency = rng.uniform(0.3, 4.0, (6, components))
        self.phase = rng.uniform(0, 2 * np.pi, (6, components))
        self.amplitude = np.array([position] * 3 + [angle] * 3)[:, None] / np.sqrt(components / 2)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Offsets ``(N, 6)``: x, y, z in metres, then yaw, pitch, roll in radians."""
        waves = np.sin(2 * np.pi * self.frequency[None] * np.asarray(t)[:, None, None] + self.phase[None])
        return np.sum(self.amplitude[None] * waves, axis=-1)


class Path:
    """Camera poses through keyframes ``(time, x, y, z, yaw, pitch, roll)`` (seconds, metres, radians)."""

    def __init__(self, keyframes, tremor: Tremor | None = None):
        keyframes = np.asarray(keyframes, np.float64)
        order = np.argsort(keyframes[:, 0], kind="stable")
        self.keyframes = keyframes[order]
        self.spline = PchipInterpolator(self.keyframes[:, 0], self.keyframes[:, 1:], axis=0, extrapolate=True)
        self.tremor = tremor

    def state(self, t) -> np.ndarray:
        """Positions and angles ``(N, 6)`` at times ``t`` (clamped to the keyframe span)."""
        t = np.clip(np.atleast_1d(np.asarray(t, np.float64)), self.keyframes[0, 0], self.keyframes[-1, 0])
        state = self.spline(t)
        if self.tremor is not None:
            state = state + self.tremor(t)
        return state

    def poses(self, t) -> np.ndarray:
        """``T_world_camera`` ``(N, 4, 4)`` at times ``t``."""
        state = self.state(t)
        return make_pose(rotation_from_angles(state[:, 3], state[:, 4], state[:, 5]), state[:, :3])


@dataclass(frozen=True)
class Timing:
    """Absolute stamps (seconds) of the colour and depth images and of the ground truth."""

    start: float
    colour: np.ndarray
    depth: np.ndarray
    groundtruth: np.ndarray


def sensor_timing(rng: np.random.Generator, frames: int) -> Timing:
    """Stamps like a Kinect recording: 30 Hz with ~2 ms jitter, depth 2-12 ms off the colour.

    Stamps are rounded to microseconds (as written in the files) before anything is rendered
    at them, so the images and ground truth agree with the file names exactly.
    """
    start = START_TIME + round(float(rng.uniform(0.0, 1.0)), 3)
    nominal = np.arange(frames) / CAMERA_RATE
    colour = start + nominal + np.clip(rng.normal(0.0, 0.002, frames), -0.005, 0.005)
    offset = rng.uniform(0.002, 0.012) * rng.choice([-1.0, 1.0])
    depth = colour + offset + np.clip(rng.normal(0.0, 0.001, frames), -0.003, 0.003)
    first = min(colour[0], depth[0]) - 0.05
    last = max(colour[-1], depth[-1]) + 0.05
    groundtruth = np.round(first + np.arange(int(np.ceil((last - first) * GROUNDTRUTH_RATE)) + 1) / GROUNDTRUTH_RATE, 4)
    return Timing(start, np.round(colour, 6), np.round(depth, 6), groundtruth)


def noisy_groundtruth(
    rng: np.random.Generator, poses: np.ndarray, position_noise: float = 0.001, angle_noise: float = np.radians(0.01)
) -> np.ndarray:
    """Motion-capture-like ground truth: ~1 mm and ~0.01 degree of white noise on each pose."""
    t, q = pose_to_tq(poses)
    t = t + rng.normal(0.0, position_noise, t.shape)
    q = q + np.concatenate([rng.normal(0.0, angle_noise / 2, (len(q), 3)), np.zeros((len(q), 1))], axis=1)
    return pose_from_tq(t, q)
