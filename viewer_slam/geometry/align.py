"""Transforms that lay an estimate's frame onto a reference's: closed-form least squares over
point sets (Horn 1987 / Umeyama 1991), or anchoring the first poses."""

import numpy as np

from .se3 import invert


def _rotations(covariance: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Proper rotations ``(H, 3, 3)`` maximising ``trace(R^T C)`` for covariances ``C = sum t s^T``,
    with the singular values and the sign that keeps each ``R`` from being a reflection."""
    U, singular, Vt = np.linalg.svd(covariance)
    sign = np.ones(singular.shape)
    sign[:, 2] = np.sign(np.linalg.det(U) * np.linalg.det(Vt))
    sign[sign == 0] = 1.0
    return (U * sign[:, None, :]) @ Vt, singular, sign


def rigid_transforms(source: np.ndarray, target: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Weighted least-squares rigid transforms ``(H, 4, 4)`` mapping point sets ``source``
    ``(H, M, 3)`` onto ``target``, one per set (Kabsch with the reflection fix), all at once.

    ``weights`` ``(H, M)`` scale each correspondence's squared residual (uniform when None).
    """
    source = np.asarray(source, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    if weights is None:
        weights = np.ones(source.shape[:2])
    weights = weights / weights.sum(axis=1, keepdims=True)
    mean_source = np.einsum("hm,hmi->hi", weights, source)
    mean_target = np.einsum("hm,hmi->hi", weights, target)
    covariance = np.einsum("hm,hmi,hmj->hij", weights, target - mean_target[:, None], source - mean_source[:, None])
    rotation = _rotations(covariance)[0]
    transforms = np.zeros((len(source), 4, 4))
    transforms[:, :3, :3] = rotation
    transforms[:, :3, 3] = mean_target - np.einsum("hij,hj->hi", rotation, mean_source)
    transforms[:, 3, 3] = 1.0
    return transforms


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
    if not with_scale:
        rigid: np.ndarray = rigid_transforms(source[None], target[None])[0]
        return rigid
    mean_source, mean_target = source.mean(axis=0), target.mean(axis=0)
    centred_source, centred_target = source - mean_source, target - mean_target
    rotations, singular, sign = _rotations((centred_target.T @ centred_source / len(source))[None])
    rotation = rotations[0]
    variance = np.mean(np.sum(centred_source**2, axis=1))
    scale = float(singular[0] @ sign[0] / variance) if variance > 0 else 1.0
    transform = np.eye(4)
    transform[:3, :3] = scale * rotation
    transform[:3, 3] = mean_target - scale * rotation @ mean_source
    return transform


def align_origin(source_pose: np.ndarray, target_pose: np.ndarray) -> np.ndarray:
    """The rigid transform ``S = target · source⁻¹`` that lays ``source_pose`` onto ``target_pose``.

    Anchoring the first poses (evo's ``--align_origin``) leaves all later error to show as
    drift from the start, where a least-squares fit would spread it over the trajectory.
    """
    anchored: np.ndarray = np.asarray(target_pose, dtype=np.float64) @ invert(source_pose)
    return anchored
