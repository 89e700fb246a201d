"""An RTAB-Map database (``rtabmap.db``) read as a run: its nodes, poses, links and statistics.

Any RTAB-Map writes one (``rtabmap-rgbd_dataset``, rtabmap_ros, the app): a SQLite file whose
``Node`` table holds each location's map id, stamp and **odometry** pose, ``Link`` its graph
edges (each stored in both directions), ``Statistics`` each location's statistics of the
update that created it, and ``Admin`` the last optimised graph. What is read here:

- a pose blob is 12 float32, the 3x4 matrix ``[R | t]`` row by row, of RTAB-Map's base frame
  (x forward, y left, z up) in a world of the same convention; it is put in the camera's
  optical frame (x right, y down, z forward) in a world whose axes are the first camera's,
  as the dataset tool's TUM export does (``T = C⁻¹ · W⁻¹ · T_base · C``, ``C`` the optical
  axes in the base frame, ``W`` the world change);
- a statistics blob is zlib-compressed text ``key:value;...`` followed by 12 bytes (the
  matrix header RTAB-Map appends: rows, columns, type);
- ``Admin.opt_ids`` / ``Admin.opt_poses`` are compressed int32 ids and float32 3x4 poses,
  the optimised graph as last saved; a node without one keeps its odometry pose only.

Nothing is trusted: a file that is not SQLite, lacks a table or holds a malformed blob is an
:class:`InputError` naming the file; decompression is bounded.
"""

import sqlite3
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .trajectory import Trajectory

SQLITE_MAGIC = b"SQLite format 3\x00"
# Link.type in RTAB-Map (Link.h): the kinds a user sees as graph edges.
LINK_KINDS = {
    0: "neighbor",
    1: "global_loop",
    2: "local_space",
    3: "local_time",
    4: "user",
    5: "virtual",
    6: "neighbor_merged",
    7: "pose_prior",
    8: "landmark",
    9: "gravity",
}
POSE_FLOATS = 12
MATRIX_HEADER_BYTES = 12  # rows, cols, type after the compressed data
MAX_INFLATED_BYTES = 64 << 20  # no statistics or graph blob inflates beyond this
# The camera's optical axes (x right, y down, z forward) in RTAB-Map's base frame.
OPTICAL_IN_BASE = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
# The dataset tool's world change before that: the world's axes swapped as its export does.
WORLD_CHANGE = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


@dataclass(frozen=True)
class RtabmapNode:
    """A location: ``odometry_pose`` from ``Node.pose``, ``pose`` from the optimised graph
    (None when the graph holds none for it), both ``T_world_camera`` in the camera frame."""

    id: int
    map_id: int
    stamp: float
    odometry_pose: np.ndarray
    pose: np.ndarray | None
    statistics: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class RtabmapLink:
    """A graph edge from the older node to the newer; ``kind`` a name of :data:`LINK_KINDS`."""

    from_id: int
    to_id: int
    kind: str


@dataclass(frozen=True)
class RtabmapDatabase:
    """The nodes (by stamp) and the links (each once) of one database."""

    path: Path
    version: str
    nodes: list[RtabmapNode]
    links: list[RtabmapLink]

    def trajectory(self, optimised: bool = True) -> Trajectory:
        """The nodes' optimised poses (a node the graph left out keeps its odometry pose), or
        with ``optimised`` False their odometry poses, at the nodes' stamps; each node that
        starts a new map is a resumption (RTAB-Map starts one after its odometry was reset or,
        in its dataset tool, lost)."""
        poses = [node.pose if optimised and node.pose is not None else node.odometry_pose for node in self.nodes]
        starts = [node.stamp for previous, node in zip(self.nodes, self.nodes[1:]) if node.map_id != previous.map_id]
        return Trajectory(
            np.array([node.stamp for node in self.nodes]), np.array(poses).reshape(-1, 4, 4), np.array(starts)
        )


def is_sqlite(path: Path) -> bool:
    """Whether ``path`` starts as a SQLite database does (an unreadable file is not one)."""
    try:
        with open(path, "rb") as file:
            return file.read(len(SQLITE_MAGIC)) == SQLITE_MAGIC
    except OSError:
        return False


def to_camera_frame(base_pose: np.ndarray) -> np.ndarray:
    """A base-frame pose in RTAB-Map's world as ``T_world_camera`` in the camera frame (module docstring)."""
    optical, world = np.eye(4), np.eye(4)
    optical[:3, :3], world[:3, :3] = OPTICAL_IN_BASE, WORLD_CHANGE
    camera: np.ndarray = np.linalg.inv(optical) @ np.linalg.inv(world) @ base_pose @ optical
    return camera


def read_rtabmap_database(path: Path) -> RtabmapDatabase:
    """The database at ``path``; every problem is an :class:`InputError` naming it."""
    path = Path(path)
    if not is_sqlite(path):
        raise InputError.at(path, "not an RTAB-Map database (not a SQLite file)")
    try:
        connection = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)
    except sqlite3.Error as error:
        raise InputError.at(path, f"cannot open the database: {error}") from error
    try:
        return _read(path, connection)
    except sqlite3.Error as error:
        raise InputError.at(path, f"not a readable RTAB-Map database: {error}") from error
    finally:
        connection.close()


def _read(path: Path, connection: sqlite3.Connection) -> RtabmapDatabase:
    tables = {row[0] for row in connection.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    missing = sorted({"Node", "Link", "Admin"} - tables)
    if missing:
        raise InputError.at(path, f"not an RTAB-Map database (no {', '.join(missing)} table)")
    admin = connection.execute("SELECT version, opt_ids, opt_poses FROM Admin").fetchone()
    version, optimised = (str(admin[0]), _optimised_poses(path, admin[1], admin[2])) if admin else ("", {})
    statistics: dict[int, dict[str, float]] = {}
    if "Statistics" in tables:
        for node_id, blob in connection.execute("SELECT id, data FROM Statistics"):
            statistics[int(node_id)] = _statistics(path, node_id, blob)
    nodes = []
    for node_id, map_id, stamp, blob in connection.execute("SELECT id, map_id, stamp, pose FROM Node ORDER BY id"):
        if node_id <= 0:
            continue  # negative ids are landmarks, not locations
        nodes.append(
            RtabmapNode(
                int(node_id),
                int(map_id),
                float(stamp),
                to_camera_frame(_pose(path, f"node {node_id}", blob)),
                optimised.get(int(node_id)),
                statistics.get(int(node_id), {}),
            )
        )
    if not nodes:
        raise InputError.at(path, "the database holds no node (no location was added)")
    nodes.sort(key=lambda node: (node.stamp, node.id))
    known = {node.id for node in nodes}
    links = sorted(
        {
            RtabmapLink(min(a, b), max(a, b), LINK_KINDS.get(kind, f"type {kind}"))
            for a, b, kind in connection.execute("SELECT from_id, to_id, type FROM Link")
            if a in known and b in known and a != b
        },
        key=lambda link: (link.to_id, link.from_id, link.kind),
    )
    return RtabmapDatabase(path, version, nodes, links)


def _pose(path: Path, what: str, blob: bytes | None) -> np.ndarray:
    if blob is None or len(blob) < 4 * POSE_FLOATS:
        raise InputError.at(path, f"{what}: no pose (a pose is {POSE_FLOATS} float32)")
    matrix = np.array(struct.unpack(f"<{POSE_FLOATS}f", bytes(blob[: 4 * POSE_FLOATS])), dtype=np.float64)
    if not np.isfinite(matrix).all():
        raise InputError.at(path, f"{what}: the pose is not finite")
    pose = np.eye(4)
    pose[:3] = matrix.reshape(3, 4)
    return pose


def _inflate(path: Path, what: str, blob: bytes | None) -> bytes:
    """The data of a compressed RTAB-Map matrix (zlib, then the 12-byte header)."""
    if blob is None or len(blob) <= MATRIX_HEADER_BYTES:
        return b""
    inflater = zlib.decompressobj()
    try:
        data = inflater.decompress(bytes(blob[:-MATRIX_HEADER_BYTES]), MAX_INFLATED_BYTES)
    except zlib.error as error:
        raise InputError.at(path, f"{what}: damaged compressed data ({error})") from error
    if inflater.unconsumed_tail:
        raise InputError.at(path, f"{what}: inflates beyond {MAX_INFLATED_BYTES >> 20} MiB")
    return data


def _optimised_poses(path: Path, id_blob: bytes | None, pose_blob: bytes | None) -> dict[int, np.ndarray]:
    ids_data, poses_data = _inflate(path, "Admin.opt_ids", id_blob), _inflate(path, "Admin.opt_poses", pose_blob)
    if len(ids_data) % 4 or len(poses_data) != len(ids_data) * POSE_FLOATS:
        raise InputError.at(path, "Admin: the optimised graph's ids and poses do not match")
    ids = np.frombuffer(ids_data, dtype="<i4")
    poses = np.frombuffer(poses_data, dtype="<f4").reshape(-1, POSE_FLOATS)
    graph = {}
    for node_id, row in zip(ids.tolist(), poses):
        if node_id > 0:
            graph[node_id] = to_camera_frame(_pose(path, f"optimised pose of node {node_id}", row.tobytes()))
    return graph


def _statistics(path: Path, node_id: int, blob: bytes | None) -> dict[str, float]:
    """``key:value;...`` as numbers; a value that is not one is left out."""
    text = _inflate(path, f"statistics of node {node_id}", blob).rstrip(b"\0").decode("utf-8", "replace")
    values = {}
    for pair in text.split(";"):
        key, colon, value = pair.rpartition(":")
        if colon and key:
            try:
                values[key] = float(value)
            except ValueError:
                continue
    return values
