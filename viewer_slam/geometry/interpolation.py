"""Poses of a trajectory at arbitrary times: linear in translation, slerp in rotation."""

import numpy as np
from scipy.spatial.transform import Rotation

from .se3 import make_pose
from .trajectory import Trajectory

DEFAULT_MAX_GAP_S = 0.1


def interpolate_poses(
    trajectory: Trajectory, stamps: np.ndarray, max_gap: float = DEFAULT_MAX_GAP_S
) -> tuple[np.ndarray, np.ndarray]:
    """Poses ``(N, 4, 4)`` at ``stamps`` and a mask of the stamps the trajectory covers.

    A stamp equal to a pose's stamp gets that pose exactly (the last one when a stamp is
    repeated). Between two poses it is interpolated, but only if they are at most
    ``max_gap`` seconds apart: motion-capture dropouts leave holes that interpolation
    would paper over. Stamps outside the covered time get NaN poses, so misuse shows.
    """
    stamps = np.asarray(stamps, dtype=np.float64).reshape(-1)
    times = trajectory.timestamps
    poses = np.full((len(stamps), 4, 4), np.nan)
    if len(times) == 0:
        return poses, np.zeros(len(stamps), dtype=bool)
    before = np.searchsorted(times, stamps, side="right") - 1
    exact = (before >= 0) & (times[np.maximum(before, 0)] == stamps)
    after = before + 1
    between = ~exact & (before >= 0) & (after < len(times))
    between[between] = times[after[between]] - times[before[between]] <= max_gap

    poses[exact] = trajectory.poses[before[exact]]
    i, j = before[between], after[between]
    fraction = (stamps[between] - times[i]) / (times[j] - times[i])
    start, end = trajectory.poses[i], trajectory.poses[j]
    translation = start[:, :3, 3] + fraction[:, None] * (end[:, :3, 3] - start[:, :3, 3])
    # Slerp of each pair (as scipy's Slerp computes it between two keys): start, turned by the
    # fraction of the rotation from start to end.
    first = Rotation.from_matrix(start[:, :3, :3])
    step = (first.inv() * Rotation.from_matrix(end[:, :3, :3])).as_rotvec()
    rotation = (first * Rotation.from_rotvec(fraction[:, None] * step)).as_matrix()
    poses[between] = make_pose(rotation, translation)
    return poses, exact | between
