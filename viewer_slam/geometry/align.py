"""Transforms that lay an estimate's frame onto a reference's: closed-form least squares over
point sets (Horn 1987 / Umeyama 1991), or anchoring the first poses."""

import numpy as np

from .se3 import invert


def align_umeyama(source: np.ndarray, target: np.ndarray, with_scale: bool = False) -> np.ndarray:
    """The 4x4 transform ``S`` minimising ``sum ||S(source_i) - target_i||^2``.

    Rigid by default (Horn's method, as TUM's ``evaluate_ate.py``); with ``with_scale`` a
    similarity whose upper-left block is ``s * R`` (for monocular trajectories of arbitrary
    scale). The sign correction keeps ``R`` a proper rotation when the points are
    degenerate or noisy enough to prefer a reflection.
    """
    source = np.asarray(source, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    if source.shape != target.shape or source.ndim != 2 or source.shape[1] != 3:
        raise ValueError(f"need two (N, 3) point sets of equal shape, got {source.shape} and {target.shape}")
    if len(source) == 0:
        raise ValueError("cannot align empty point sets")
    mean_source, mean_target = source.mean(axis=0), target.mean(axis=0)
    centred_source, centred_target = source - mean_source, target - mean_target
    covariance = centred_target.T @ centred_source / len(source)
    U, singular, Vt = np.linalg.svd(covariance)
    sign = np.ones(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        sign[2] = -1.0
    rotation = (U * sign) @ Vt
    scale = 1.0
    if with_scale:
        variance = np.mean(np.sum(centred_source**2, axis=1))
        scale = float(singular @ sign / variance) if variance > 0 else 1.0
    transform = np.eye(4)
    transform[:3, :3] = scale * rotation
    transform[:3, 3] = mean_target - scale * rotation @ mean_source
    return transform


def align_origin(source_pose: np.ndarray, target_pose: np.ndarray) -> np.ndarray:
    """The rigid transform ``S = target · source⁻¹`` that lays ``source_pose`` onto ``target_pose``.

    Anchoring the first poses (evo's ``--align_origin``) leaves all later error to show as
    drift from the start, where a least-squares fit would spread it over the trajectory.
    """
    return np.asarray(target_pose, dtype=np.float64) @ invert(source_pose)
