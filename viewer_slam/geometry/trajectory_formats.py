"""Trajectory files as other SLAM systems write them: TUM, KITTI poses, EuRoC/ASL CSV and
RTAB-Map databases.

- ``tum``: ``timestamp tx ty tz qx qy qz qw`` per line, seconds, quaternion scalar last
  (what viewslam itself writes).
- ``kitti``: 12 numbers per line, the 3x4 matrix ``[R | t]`` of ``T_world_camera`` row by
  row, and no time: line *i* is the *i*-th timestamp given with the file (the frame stamps
  of the sequence the poses were estimated on, or a times file).
- ``euroc``: a CSV whose header names the columns, timestamps in nanoseconds, quaternion
  scalar first: the EuRoC/ASL ground truth (``#timestamp, p_RS_R_x [m], ..., q_RS_w [],
  q_RS_x [], ...``; velocity and bias columns ignored) and estimate files such as
  ``#timestamp [ns],tx,ty,tz,qw,qx,qy,qz``.
- ``rtabmap``: an ``rtabmap.db``, its nodes' optimised poses (:mod:`.rtabmap_database`).

Detection: a SQLite file is ``rtabmap``; otherwise it looks at the first line that is not
blank: a comma-separated header of at least eight names, the first a timestamp, means
``euroc``; otherwise 12 numbers on the first data line mean ``kitti``; anything else is read
as ``tum``.
"""

import re
from collections.abc import Iterator, Sequence
from enum import StrEnum
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError
from .rtabmap_database import RtabmapDatabase, is_sqlite, read_rtabmap_database
from .se3 import make_pose, pose_from_tq
from .trajectory import Trajectory, parse_numbers, pose_problem, read_text, read_tum


class TrajectoryFormat(StrEnum):
    """A trajectory file format; the value is the name ``--format`` takes and reports record."""

    TUM = "tum"
    KITTI = "kitti"
    EUROC = "euroc"
    RTABMAP = "rtabmap"


KITTI_FIELDS = 12
# How far R^T R of a KITTI pose may be from the identity (files print 6 to 9 digits).
ORTHONORMAL_TOLERANCE = 1e-3
_TIMESTAMP_NAMES = ("timestamp", "time", "t", "stamp")
_POSITION_NAMES = {
    axis: (f"p_rs_r_{axis}", f"t{axis}", axis, f"p{axis}", f"p_{axis}", f"pos_{axis}", f"position_{axis}")
    for axis in "xyz"
}
_QUATERNION_NAMES = {axis: (f"q_rs_{axis}", f"q{axis}", f"q_{axis}", f"orientation_{axis}") for axis in "xyzw"}


def read_trajectory(
    path: Path, format: str | None = None, timestamps: Sequence[float] | np.ndarray | Path | None = None
) -> tuple[Trajectory, TrajectoryFormat]:
    """The trajectory in ``path`` and its format (detected unless ``format``, one of
    :class:`TrajectoryFormat` or its value, is given).

    ``timestamps`` gives a KITTI file its times: one per pose, in order, as an array or a
    file whose lines start with them (KITTI's ``times.txt``, a TUM ``rgb.txt``). Stamps
    must increase strictly. Every problem is an :class:`InputError` naming the file and,
    where there is one, the line.
    """
    path = Path(path)
    if format is not None and format not in tuple(TrajectoryFormat):
        raise InputError.at(path, f"unknown trajectory format {format!r}; valid: {', '.join(TrajectoryFormat)}")
    if reads_as_rtabmap(path, format):
        return read_rtabmap_database(path).trajectory(), TrajectoryFormat.RTABMAP
    text = read_text(path)
    kind = detect_format(path, text) if format is None else TrajectoryFormat(format)
    if kind is TrajectoryFormat.TUM:
        return read_tum(path, in_order=True), kind
    if kind is TrajectoryFormat.KITTI:
        return _read_kitti(path, text, timestamps), kind
    return _read_euroc(path, text), kind


def read_estimate(
    path: Path, format: str | None = None, timestamps: np.ndarray | None = None
) -> tuple[Trajectory, TrajectoryFormat, RtabmapDatabase | None]:
    """An estimate file (``format``, else detected), the format it was read as and, for an RTAB-Map
    database, the database itself: its nodes, links and statistics say more than its poses."""
    if reads_as_rtabmap(path, format):
        database = read_rtabmap_database(path)
        return database.trajectory(), TrajectoryFormat.RTABMAP, database
    trajectory, detected = read_trajectory(path, format, timestamps)
    return trajectory, detected, None


def reads_as_rtabmap(path: Path, format: str | None = None) -> bool:
    """Whether ``path`` is read as an RTAB-Map database: ``format`` says so, or none is given
    and the file is SQLite."""
    return format == TrajectoryFormat.RTABMAP or (format is None and is_sqlite(path))


def detect_format(path: Path, text: str | None = None) -> TrajectoryFormat:
    """``rtabmap``, ``euroc``, ``kitti`` or ``tum`` by the rule in the module docstring."""
    if text is None and is_sqlite(path):
        return TrajectoryFormat.RTABMAP
    lines = [line for _, line in _lines(read_text(path) if text is None else text)]
    if not lines:
        raise InputError.at(path, "no poses in trajectory file")
    if _header_names(lines[0]) is not None:
        return TrajectoryFormat.EUROC
    first_data = next((line for line in lines if not line.startswith("#")), "")
    return TrajectoryFormat.KITTI if len(first_data.replace(",", " ").split()) == KITTI_FIELDS else TrajectoryFormat.TUM


def _lines(text: str) -> Iterator[tuple[int, str]]:
    """``(line number, stripped line)`` of the lines that are not blank."""
    for number, line in enumerate(text.splitlines(), start=1):
        if line.strip():
            yield number, line.strip()


def _header_names(line: str) -> list[str] | None:
    """The normalised column names if ``line`` is a CSV header whose first column is a timestamp."""
    names = [re.sub(r"\[.*?\]", "", name).strip().lower() for name in line.lstrip("#").split(",")]
    if len(names) < 8 or names[0] not in _TIMESTAMP_NAMES:
        return None
    return names


def _check_increasing(path: Path, stamps: list[float], numbers: list[int]) -> None:
    for k in range(1, len(stamps)):
        if stamps[k] <= stamps[k - 1]:
            raise InputError.at(
                path, f"timestamp {stamps[k]:.9f} does not increase (previous {stamps[k - 1]:.9f})", numbers[k]
            )


def _read_kitti(path: Path, text: str, timestamps: Sequence[float] | np.ndarray | Path | None) -> Trajectory:
    rows = [(number, line.split()) for number, line in _lines(text) if not line.startswith("#")]
    if not rows:
        raise InputError.at(path, "no poses in trajectory file")
    if timestamps is None:
        raise InputError.at(
            path,
            "KITTI poses carry no timestamps; evaluate them against a sequence "
            "(its frame stamps are used) or give a times file",
        )
    stamps = _times(Path(timestamps)) if isinstance(timestamps, (str, Path)) else np.asarray(timestamps, float)
    if len(stamps) != len(rows):
        raise InputError.at(
            path,
            f"{len(rows)} KITTI poses but {len(stamps)} timestamps; the file must hold "
            f"one pose per frame of the sequence",
        )
    matrices = np.empty((len(rows), 3, 4))
    for k, (number, fields) in enumerate(rows):
        if len(fields) != KITTI_FIELDS:
            raise InputError.at(
                path, f"expected {KITTI_FIELDS} fields (a 3x4 pose, row by row), found {len(fields)}", number
            )
        matrices[k] = np.reshape(parse_numbers(path, fields, number), (3, 4))
        problem = pose_problem(matrices[k, :, 3])
        if problem is not None:
            raise InputError.at(path, problem, number)
        rotation = matrices[k, :, :3]
        if np.linalg.det(rotation) <= 0 or np.abs(rotation.T @ rotation - np.eye(3)).max() > ORTHONORMAL_TOLERANCE:
            raise InputError.at(path, "the 3x3 block is not a rotation matrix", number)
    # The nearest exact rotation, as a TUM reader normalises its quaternions.
    rotations = Rotation.from_matrix(matrices[:, :, :3]).as_matrix()
    return Trajectory(stamps, make_pose(rotations, matrices[:, :, 3]))


def _times(path: Path) -> np.ndarray:
    """The first number of each line of a times file (``#`` comments skipped)."""
    text = read_text(path)
    stamps, numbers = [], []
    for number, line in _lines(text):
        if not line.startswith("#"):
            stamps.append(parse_numbers(path, line.replace(",", " ").split()[:1], number)[0])
            numbers.append(number)
    _check_increasing(path, stamps, numbers)
    return np.array(stamps)


def _read_euroc(path: Path, text: str) -> Trajectory:
    lines = list(_lines(text))
    header_number, header = lines[0] if lines else (None, "")
    names = _header_names(header)
    if names is None:
        raise InputError.at(
            path,
            "not an EuRoC/ASL CSV: the first line must be a header such as '#timestamp [ns],tx,ty,tz,qw,qx,qy,qz'",
            header_number,
        )
    columns = [_column(path, header_number, names, _POSITION_NAMES[axis], f"position {axis}") for axis in "xyz"] + [
        _column(path, header_number, names, _QUATERNION_NAMES[axis], f"quaternion {axis}") for axis in "xyzw"
    ]
    in_seconds = "[s]" in header.split(",")[0]
    stamps, values, numbers = [], [], []
    for number, line in lines[1:]:
        if line.startswith("#"):
            continue
        fields = [field.strip() for field in line.split(",")]
        if len(fields) != len(names):
            raise InputError.at(path, f"expected {len(names)} fields as the header names, found {len(fields)}", number)
        row = parse_numbers(path, [fields[c] for c in columns], number)
        problem = pose_problem(row[:3], row[3:])
        if problem is not None:
            raise InputError.at(path, problem, number)
        stamps.append(_stamp(path, fields[0], number, in_seconds))
        values.append(row)
        numbers.append(number)
    if not values:
        raise InputError.at(path, "no poses in trajectory file")
    _check_increasing(path, stamps, numbers)
    data = np.array(values)
    return Trajectory(np.array(stamps), pose_from_tq(data[:, :3], data[:, 3:]))


def _column(path: Path, header_number: int | None, names: list[str], candidates: tuple[str, ...], what: str) -> int:
    for candidate in candidates:
        if candidate in names:
            return names.index(candidate)
    raise InputError.at(path, f"the header names no {what} column (looked for {', '.join(candidates)})", header_number)


def _stamp(path: Path, field: str, number: int, in_seconds: bool) -> float:
    """Seconds from a stamp. Integer nanoseconds are divided as integers: a float would round them."""
    if in_seconds:
        return parse_numbers(path, [field], number)[0]
    if field.isdigit():
        return int(field) / 10**9
    return parse_numbers(path, [field], number)[0] / 1e9
