"""Relative pose error (Sturm et al. 2012, eq. 4-5) and the choice of pose pairs it uses."""

from enum import StrEnum

import numpy as np

from ..geometry.se3 import rotation_angle


class DeltaUnit(StrEnum):
    """What RPE's Δ counts; the value is the name ``--delta-unit`` takes and reports record."""

    FRAMES = "frames"
    SECONDS = "seconds"


def pairs_by_frames(count: int, delta: int) -> tuple[np.ndarray, np.ndarray]:
    """Every pair ``(i, i + delta)`` (overlapping, as TUM's evaluate_rpe)."""
    first = np.arange(max(count - delta, 0))
    return first, first + delta


def pairs_by_seconds(stamps: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """Each pose ``i`` with the first pose at or after ``t_i + delta`` (dropped when none)."""
    second = np.searchsorted(stamps, stamps + delta, side="left")
    first = np.flatnonzero(second < len(stamps))
    return first, second[first]


def sampled_pairs(count: int, samples: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``samples`` random pairs over all frame distances, each distance equally likely.

    Eq. 5 of Sturm et al. averages the RPE over every Δ = 1..n-1; drawing Δ uniformly and
    then ``i`` uniformly among the pairs at that Δ estimates that average in fixed time.
    """
    if count < 2:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    rng = np.random.default_rng(seed)
    delta = rng.integers(1, count, size=samples)
    first = np.floor(rng.random(samples) * (count - delta)).astype(int)
    return first, first + delta


def relative_errors(
    reference: np.ndarray, estimate: np.ndarray, first: np.ndarray, second: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Translation (metres) and rotation (degrees) of ``E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)``.

    ``||trans(E)|| = ||R_Qi^T (q_j - q_i) - R_Pi^T (p_j - p_i)||`` since rotating a vector
    keeps its length, so only rotations are multiplied.
    """
    reference_motion = _relative_motion(reference, first, second)
    estimate_motion = _relative_motion(estimate, first, second)
    translation = np.linalg.norm(reference_motion[1] - estimate_motion[1], axis=1)
    rotation = np.swapaxes(reference_motion[0], 1, 2) @ estimate_motion[0]
    return translation, np.degrees(rotation_angle(rotation))


def _relative_motion(poses: np.ndarray, first: np.ndarray, second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations ``R_i^T R_j`` and translations ``R_i^T (t_j - t_i)`` of ``T_i^-1 T_j``."""
    rotation_t = np.swapaxes(poses[first, :3, :3], 1, 2)
    step = poses[second, :3, 3] - poses[first, :3, 3]
    return rotation_t @ poses[second, :3, :3], np.einsum("nij,nj->ni", rotation_t, step)
