"""Trajectories, independent oracles and the shared TUM excerpt used across the tests."""

import shutil
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from viewer_slam.geometry.se3 import make_pose
from viewer_slam.geometry.trajectory import Trajectory

# The shared data sits beside the checkout (``/work/shared`` for ``/work/main``, also for a
# worktree deeper down): the nearest ancestor that has it.
SHARED_DATA = next(
    (
        parent / "shared" / "data"
        for parent in Path(__file__).resolve().parents
        if (parent / "shared" / "data").is_dir()
    ),
    Path(__file__).resolve().parents[3] / "shared" / "data",
)
TRAJECTORIES = SHARED_DATA / "trajectories"
TUM_RPY = SHARED_DATA / "tum" / "rgbd_dataset_freiburg1_rpy"


def random_walk(count: int, seed: int, rate_hz: float = 30.0, start: float = 100.0) -> Trajectory:
    """A smooth-ish hand-held camera: random steps of ~1 cm and ~1 degree per frame."""
    rng = np.random.default_rng(seed)
    poses = np.empty((count, 4, 4))
    pose = np.eye(4)
    for i in range(count):
        poses[i] = pose
        step = make_pose(
            Rotation.from_rotvec(rng.normal(scale=0.02, size=3)).as_matrix(), rng.normal(scale=0.01, size=3)
        )
        pose = pose @ step
    return Trajectory(start + np.arange(count) / rate_hz, poses)


def perturbed(trajectory: Trajectory, seed: int, sigma_m: float = 0.005, sigma_rad: float = 0.005) -> Trajectory:
    """The same stamps with every pose disturbed independently."""
    rng = np.random.default_rng(seed)
    noise = [
        make_pose(
            Rotation.from_rotvec(rng.normal(scale=sigma_rad, size=3)).as_matrix(), rng.normal(scale=sigma_m, size=3)
        )
        for _ in range(len(trajectory))
    ]
    return Trajectory(trajectory.timestamps, trajectory.poses @ np.array(noise))


def read_tum_file_list(path: Path) -> dict[float, list[float]]:
    """TUM's read_file_list: a dict keyed by timestamp, so a repeated stamp keeps its last row."""
    rows = {}
    for line in Path(path).read_text().replace(",", " ").replace("\t", " ").split("\n"):
        if len(line) > 0 and line[0] != "#":
            fields = [v for v in line.split(" ") if v.strip() != ""]
            if len(fields) > 1:
                rows[float(fields[0])] = fields[1:]
    return rows


def tum_associate(first: list[float], second: list[float], offset: float, max_difference: float):
    """TUM associate.py restated: all candidates within max_difference, sorted, taken greedily.

    Candidate generation is a blocked all-against-all comparison (as the script's double
    loop, just not in pure Python); the selection is the script's greedy loop verbatim.
    """
    first_keys, second_keys = sorted(set(first)), sorted(set(second))
    a_all, b_all = np.array(first_keys), np.array(second_keys)
    potential_matches = []
    for block in range(0, len(a_all), 1000):
        a = a_all[block : block + 1000]
        difference = np.abs(a[:, None] - (b_all[None, :] + offset))
        rows, cols = np.nonzero(difference < max_difference)
        potential_matches += [(float(difference[r, c]), float(a[r]), float(b_all[c])) for r, c in zip(rows, cols)]
    potential_matches.sort()
    remaining_first, remaining_second = set(first_keys), set(second_keys)
    matches = []
    for _, a, b in potential_matches:
        if a in remaining_first and b in remaining_second:
            remaining_first.remove(a)
            remaining_second.remove(b)
            matches.append((a, b))
    matches.sort()
    return matches


def tum_horn_errors(model: np.ndarray, data: np.ndarray) -> np.ndarray:
    """TUM evaluate_ate.py's align(): Horn's method on 3xN columns, per-pair translation errors."""
    model_zerocentered = model - model.mean(1, keepdims=True)
    data_zerocentered = data - data.mean(1, keepdims=True)
    W = np.zeros((3, 3))
    for column in range(model.shape[1]):
        W += np.outer(model_zerocentered[:, column], data_zerocentered[:, column])
    U, d, Vh = np.linalg.svd(W.transpose())
    S = np.identity(3)
    if np.linalg.det(U) * np.linalg.det(Vh) < 0:
        S[2, 2] = -1
    rot = U @ S @ Vh
    trans = data.mean(1, keepdims=True) - rot @ model.mean(1, keepdims=True)
    alignment_error = rot @ model + trans - data
    return np.sqrt(np.sum(alignment_error * alignment_error, 0))


def tum_excerpt(folder: Path, frames: int) -> Path:
    """The first ``frames`` colour and depth images of the shared fr1/rpy excerpt, with its groundtruth."""
    for listing in ("rgb.txt", "depth.txt"):
        lines = (TUM_RPY / listing).read_text().splitlines()
        header = [line for line in lines if line.startswith("#")]
        kept = [line for line in lines if not line.startswith("#")][:frames]
        (folder / listing.removesuffix(".txt")).mkdir(parents=True)
        for line in kept:
            shutil.copy(TUM_RPY / line.split()[1], folder / line.split()[1])
        (folder / listing).write_text("\n".join(header + kept) + "\n")
    shutil.copy(TUM_RPY / "groundtruth.txt", folder / "groundtruth.txt")
    return folder
