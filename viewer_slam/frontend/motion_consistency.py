"""How much of a matched scene moves with the camera: the measurement behind the "dynamic scene" cause.

A static point seen in two frames lands, under the camera motion estimated between them,
where it was measured; a point on a person or a moved box does not. The share of matched
points whose residual under the estimated motion exceeds the pipeline's inlier threshold
is what a pipeline reports as ``FrameTracked.metrics["dynamic_share"]``
(:data:`viewer_slam.pipelines.events.DYNAMIC_SHARE_METRIC`), and the diagnosis calls a
loss a dynamic scene when it reaches the ``dynamic_share`` threshold (docs/diagnosis.md).
"""

import numpy as np

from ..geometry.se3 import transform_points


def motion_residuals(source: np.ndarray, target: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """Distance from each ``target`` point to its ``source`` point moved by ``motion`` (4x4, source -> target frame).

    ``source`` and ``target`` are matched 3D points ``(N, 3)``, row ``i`` of one matching row
    ``i`` of the other; a pair with a non-finite coordinate (no depth) has a NaN residual.
    """
    source, target = np.asarray(source, dtype=np.float64), np.asarray(target, dtype=np.float64)
    if source.shape != target.shape or source.ndim != 2 or source.shape[1] != 3:
        raise ValueError(f"expected two (N, 3) arrays of matched points, got {source.shape} and {target.shape}")
    return np.linalg.norm(transform_points(np.asarray(motion, dtype=np.float64), source) - target, axis=1)


def inconsistent_share(
    source: np.ndarray, target: np.ndarray, motion: np.ndarray, threshold: float | np.ndarray
) -> float:
    """The share (0 to 1) of matched points whose residual under ``motion`` exceeds ``threshold``.

    ``threshold`` is in the points' unit (metres), one for all pairs or one per pair (a noise
    model that grows with depth). Pairs without a finite residual are left out; with none
    left the share is NaN (nothing was measured), which the diagnosis reads as "not reported".
    """
    residuals = motion_residuals(source, target, motion)
    bounds = np.broadcast_to(np.asarray(threshold, dtype=np.float64), residuals.shape)
    measured = np.isfinite(residuals)
    if not measured.any():
        return float("nan")
    return float(np.mean(residuals[measured] > bounds[measured]))
