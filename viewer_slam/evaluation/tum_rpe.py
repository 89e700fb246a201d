"""RPE as TUM's ``evaluate_rpe.py`` computes it with its default options, pair for pair.

Published RGB-D SLAM figures (the study viewslam reproduces among them) were printed by
that script with no options, which does not evaluate the drift per second that its
documentation describes but an average over *all* pose pairs (Δ of every length, either
direction, and each pose with itself): every ordered pair ``(i, j)`` when the estimate has
fewer than ``sqrt(max_pairs)`` = 100 poses, else ``max_pairs`` = 10,000 pairs of
``random.randint`` indices after ``random.seed(0)``, drawn by the Python that ran it
(2.7 for the published figures: :mod:`.python27_random`). A pair is dropped when either
estimate stamp has no groundtruth stamp within twice the groundtruth's median interval.

The error is the script's ``E = (P_j^-1 P_i)^-1 (Q_j^-1 Q_i)``, whose translation differs
from the ``(Q_i^-1 Q_j)^-1 (P_i^-1 P_j)`` of :mod:`.rpe` (the rotation angle is the
same), the closest stamps come from the script's own binary search, and duplicate stamps
keep their last row (the script reads a dict): each choice changes printed digits, so each
is the script's. Pure numpy; imports nothing but :mod:`.python27_random`.
"""

from dataclasses import dataclass

import numpy as np

from .python27_random import Python27Random

MAX_PAIRS = 10_000
SEED = 0
MODE_TEXT = (
    "TUM evaluate_rpe.py's default: all pose pairs under 100 poses, else 10,000 pairs drawn by "
    "Python 2.7's random seeded 0"
)


@dataclass
class TumRpe:
    """The pairs the script compares and their errors: estimate stamps of each pair (first,
    second), translation in metres, rotation in radians, as the script's ``--save`` lists them."""

    first_stamps: np.ndarray
    second_stamps: np.ndarray
    translation: np.ndarray
    rotation: np.ndarray


def find_closest_index(values: list[float], target: float) -> int:
    """The script's binary search: the closest of the values it visits (first one on a tie)."""
    beginning, end = 0, len(values)
    difference = abs(values[0] - target)
    best = 0
    while beginning < end:
        middle = (end + beginning) // 2
        if abs(values[middle] - target) < difference:
            difference = abs(values[middle] - target)
            best = middle
        if target == values[middle]:
            return middle
        if values[middle] > target:
            end = middle
        else:
            beginning = middle + 1
    return best


def pair_indices(count: int, max_pairs: int = MAX_PAIRS, seed: int = SEED) -> tuple[np.ndarray, np.ndarray]:
    """The script's pairs of pose indices over ``count`` poses (sorted by stamp).

    ``(i, j)`` for every i, j when ``max_pairs`` is 0 or ``count < sqrt(max_pairs)``; else
    ``max_pairs`` pairs ``(randint(0, count-1), randint(0, count-1))`` in draw order, from a
    Python 2.7 generator seeded with ``seed`` (the script seeds once, at start).
    """
    if max_pairs == 0 or count < np.sqrt(max_pairs):
        first, second = np.meshgrid(np.arange(count), np.arange(count), indexing="ij")
        return first.reshape(-1), second.reshape(-1)
    generator = Python27Random(seed)
    drawn = np.array([generator.randint(0, count - 1) for _ in range(2 * max_pairs)], dtype=int)
    return drawn[0::2], drawn[1::2]


def _last_row_per_stamp(stamps: np.ndarray, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted distinct stamps and the pose of each one's last row (the script's dict)."""
    unique, reversed_index = np.unique(stamps[::-1], return_index=True)
    return unique, poses[len(stamps) - 1 - reversed_index]


def tum_rpe(
    groundtruth_stamps: np.ndarray,
    groundtruth_poses: np.ndarray,
    estimate_stamps: np.ndarray,
    estimate_poses: np.ndarray,
    *,
    max_pairs: int = MAX_PAIRS,
    seed: int = SEED,
    offset: float = 0.0,
    scale: float = 1.0,
) -> TumRpe:
    """``evaluate_rpe.py GT EST`` with ``--max_pairs``, ``--offset``, ``--scale`` as given and no
    ``--fixed_delta``; poses are 4x4 camera-to-world. ValueError where the script raises
    (fewer than 2 comparable pairs)."""
    gt_stamps, gt_poses = _last_row_per_stamp(np.asarray(groundtruth_stamps, float), np.asarray(groundtruth_poses))
    est_stamps, est_poses = _last_row_per_stamp(np.asarray(estimate_stamps, float), np.asarray(estimate_poses))
    if len(est_stamps) < 2 or len(gt_stamps) < 2:
        raise ValueError("Number of overlap in the timestamps is too small (fewer than 2 poses)")
    gt_list = gt_stamps.tolist()
    closest = np.array([find_closest_index(gt_list, stamp + offset) for stamp in est_stamps.tolist()])
    max_time_difference = 2 * np.median(np.diff(gt_stamps))
    usable = np.abs(gt_stamps[closest] - (est_stamps + offset)) <= max_time_difference

    first, second = pair_indices(len(est_stamps), max_pairs, seed)
    keep = usable[first] & usable[second]
    first, second = first[keep], second[keep]
    if len(first) < 2:
        raise ValueError("Couldn't find matching timestamp pairs between groundtruth and estimated trajectory")

    inverse_est = np.linalg.inv(est_poses)
    inverse_gt = np.linalg.inv(gt_poses)
    estimate_motion = inverse_est[second] @ est_poses[first]  # ominus(P_j, P_i)
    estimate_motion[:, :3, 3] *= scale
    gt_first, gt_second = closest[first], closest[second]
    reference_motion = inverse_gt[gt_second] @ gt_poses[gt_first]  # ominus(Q_j, Q_i)
    error = np.linalg.inv(estimate_motion) @ reference_motion
    translation = np.linalg.norm(error[:, :3, 3], axis=1)
    cosine = (np.trace(error[:, :3, :3], axis1=1, axis2=2) - 1) / 2
    rotation = np.arccos(np.minimum(1, np.maximum(-1, cosine)))
    return TumRpe(est_stamps[first], est_stamps[second], translation, rotation)
