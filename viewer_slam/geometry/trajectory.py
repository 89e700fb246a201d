"""Timestamped pose sequences and the TUM trajectory file format."""

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .se3 import pose_from_tq, pose_to_tq


@dataclass
class Trajectory:
    """``timestamps (N,)`` in seconds and poses ``(N, 4, 4)`` ``T_world_camera``.

    ``resumptions`` are the stamps of poses at which the trajectory's source says it resumed
    after losing track (an RTAB-Map database's first node of each new map): the gap before
    each is lost, however short or however sparse the poses around it.
    """

    timestamps: np.ndarray
    poses: np.ndarray
    resumptions: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        self.timestamps = np.asarray(self.timestamps, dtype=np.float64).reshape(-1)
        self.poses = np.asarray(self.poses, dtype=np.float64).reshape(-1, 4, 4)
        self.resumptions = np.asarray(self.resumptions, dtype=np.float64).reshape(-1)
        if len(self.timestamps) != len(self.poses):
            raise ValueError("timestamps and poses differ in length")

    def __len__(self) -> int:
        return len(self.timestamps)

    @property
    def positions(self) -> np.ndarray:
        return self.poses[:, :3, 3]

    def subset(self, index: np.ndarray | slice) -> "Trajectory":
        """The poses at ``index``, with the resumptions among them."""
        timestamps = self.timestamps[index]
        return Trajectory(timestamps, self.poses[index], self.resumptions[np.isin(self.resumptions, timestamps)])

    @classmethod
    def empty(cls) -> "Trajectory":
        return cls(np.zeros(0), np.zeros((0, 4, 4)))


def read_text(path: Path) -> str:
    """The text of a trajectory file; a missing or unreadable file is an :class:`InputError`.

    A UTF-8 byte-order mark (some Windows editors write one) is dropped.
    """
    try:
        return Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError.at(path, "no such file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError.at(path, f"cannot read: {error}") from None


def parse_numbers(path: Path, fields: list[str], line: int) -> list[float]:
    """The fields of line ``line`` of ``path`` as finite numbers, else an :class:`InputError` there."""
    try:
        values = [float(field) for field in fields]
    except ValueError:
        raise InputError.at(path, "a field is not a number", line) from None
    if not all(math.isfinite(value) for value in values):
        raise InputError.at(path, "a field is NaN or infinite", line)
    return values


# Positions beyond this (metres; 100,000 km) are no camera's, and their squares would overflow
# nothing but still drown every other error.
MAX_COORDINATE_M = 1e8


def pose_problem(
    translation: Sequence[float] | np.ndarray, quaternion: Sequence[float] | np.ndarray | None = None
) -> str | None:
    """What keeps a position (and an xyzw quaternion) read from a file from being a pose, or None:
    a value that is not finite, a coordinate beyond :data:`MAX_COORDINATE_M`, a zero quaternion
    or one too large to normalise."""
    values = [*translation, *(quaternion if quaternion is not None else ())]
    if not all(math.isfinite(value) for value in values):
        return "a pose value is NaN or infinite"
    if max(abs(value) for value in translation) > MAX_COORDINATE_M:
        return f"a position coordinate beyond {MAX_COORDINATE_M:g} m"
    if quaternion is not None:
        norm = math.hypot(*quaternion)
        if norm < 1e-9:
            return "zero quaternion"
        if norm > MAX_COORDINATE_M:
            return f"a quaternion of norm beyond {MAX_COORDINATE_M:g}"
    return None


def read_tum(path: Path, *, in_order: bool = False) -> Trajectory:
    """Read ``timestamp tx ty tz qx qy qz qw`` lines; ``#`` comments and blank lines skipped.

    Every malformed line raises :class:`InputError` naming the file and line number. Lines
    out of time order are sorted, unless ``in_order`` demands strictly increasing stamps
    (an estimate whose stamps go backwards is more likely broken than shuffled).
    """
    path = Path(path)
    text = read_text(path)
    rows: list[list[float]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        fields = stripped.replace(",", " ").split()
        if len(fields) != 8:
            raise InputError.at(
                path, f"expected 8 fields (timestamp tx ty tz qx qy qz qw), found {len(fields)}", number
            )
        values = parse_numbers(path, fields, number)
        problem = pose_problem(values[1:4], values[4:])
        if problem is not None:
            raise InputError.at(path, problem, number)
        if in_order and rows and values[0] <= rows[-1][0]:
            raise InputError.at(path, f"timestamp {fields[0]} does not increase (previous {rows[-1][0]:.6f})", number)
        rows.append(values)
    if not rows:
        raise InputError.at(path, "no poses in trajectory file")
    data = np.array(rows)
    if np.any(np.diff(data[:, 0]) < 0):
        order = np.argsort(data[:, 0], kind="stable")
        data = data[order]
    return Trajectory(data[:, 0], pose_from_tq(data[:, 1:4], data[:, 4:8]))


def format_tum(trajectory: Trajectory) -> str:
    t, q = pose_to_tq(trajectory.poses)
    lines = [
        f"{stamp:.6f} {x:.6f} {y:.6f} {z:.6f} {qx:.6f} {qy:.6f} {qz:.6f} {qw:.6f}"
        for stamp, (x, y, z), (qx, qy, qz, qw) in zip(trajectory.timestamps, t, q)
    ]
    return "".join(line + "\n" for line in lines)


def write_tum(path: Path, trajectory: Trajectory) -> None:
    """Write a trajectory in TUM format (6 decimals: micro-seconds and micro-metres)."""
    Path(path).write_text(format_tum(trajectory))
