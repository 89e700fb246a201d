"""Absolute trajectory error (Sturm et al. 2012, eq. 2-3)."""

import numpy as np


def absolute_errors(
    reference_positions: np.ndarray, estimate_positions: np.ndarray, alignment: np.ndarray
) -> np.ndarray:
    """``||trans(Q_i^-1 S P_i)||`` for every associated pair, computed as ``||S p_i - q_i||``.

    ``alignment`` is S (estimate frame → reference frame), rigid or a similarity: one 4x4
    for every pair, or ``(N, 4, 4)``, one per pair (each tracked segment aligned on its own).
    """
    aligned = np.einsum("...ij,...j->...i", alignment[..., :3, :3], estimate_positions) + alignment[..., :3, 3]
    errors: np.ndarray = np.linalg.norm(aligned - reference_positions, axis=1)
    return errors
