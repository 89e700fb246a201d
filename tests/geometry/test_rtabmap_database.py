"""RTAB-Map databases read as runs, checked against what RTAB-Map 0.23.8 itself wrote.

The fixtures are two databases the real RTAB-Map 0.23.8 (``rtabmap-rgbd_dataset``) wrote on
the synthetic 360_kidnap (640x480, seed 0), with their images and features removed, and the
tool's own TUM export of the optimised graph beside each (``tests/data/rtabmap/SOURCE.md``).
"""

import re
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.errors import InputError
from viewer_slam.geometry.rtabmap_database import read_rtabmap_database
from viewer_slam.geometry.trajectory_formats import TrajectoryFormat, detect_format, read_trajectory

DATA = Path(__file__).resolve().parents[1] / "data" / "rtabmap"
ROS_RULE = DATA / "360_kidnap-rosrule.db"  # one map: the tool exports the database's own graph
TOOL_RULE = DATA / "360_kidnap-toolrule.db"  # four maps joined by loop closures and proximity links
FLOAT32_M = 2e-6  # the poses are float32, the export prints 6 decimals
# The tool optimises the whole graph once more before its export; on the four-map run its poses
# differ from the database's last saved graph by 3.9 mm at most.
REOPTIMISED_M = 0.01
NOT_ZLIB = b"not zlib data" + bytes(12)  # a compressed blob's place: data, then the matrix header


def tool_export(database: Path) -> np.ndarray:
    return np.loadtxt(database.with_suffix(".poses.txt"))


def test_the_optimised_poses_are_those_rtabmap_exports():
    trajectory, kind = read_trajectory(ROS_RULE)
    exported = tool_export(ROS_RULE)
    assert kind is TrajectoryFormat.RTABMAP
    np.testing.assert_array_equal(trajectory.timestamps, exported[:, 0])
    np.testing.assert_allclose(trajectory.poses[:, :3, 3], exported[:, 1:4], rtol=0, atol=FLOAT32_M)
    ours = Rotation.from_matrix(trajectory.poses[:, :3, :3])
    angle = (ours.inv() * Rotation.from_quat(exported[:, 4:])).magnitude()
    assert angle.max() < 1e-5


def test_maps_links_and_statistics_are_the_databases():
    database = read_rtabmap_database(TOOL_RULE)
    with sqlite3.connect(TOOL_RULE) as raw:
        nodes, maps = raw.execute("SELECT count(*), count(DISTINCT map_id) FROM Node WHERE id > 0").fetchone()
        stored = dict(raw.execute("SELECT type, count(*) FROM Link GROUP BY type").fetchall())
    assert database.version == "0.23.8"
    assert len(database.nodes) == nodes == 8 and len({node.map_id for node in database.nodes}) == maps == 4
    kinds = [link.kind for link in database.links]
    # each link is stored in both directions and read once
    assert {kind: kinds.count(kind) for kind in set(kinds)} == {
        "neighbor": stored[0] // 2,
        "global_loop": stored[1] // 2,
        "local_space": stored[2] // 2,
    }
    assert all(link.from_id < link.to_id for link in database.links)
    assert [node.stamp for node in database.nodes] == sorted(node.stamp for node in database.nodes)
    assert all(node.statistics["Odometry/Inliers/"] >= 20 for node in database.nodes[1:])  # Vis/MinInliers
    np.testing.assert_allclose(
        database.trajectory().poses[:, :3, 3], tool_export(TOOL_RULE)[:, 1:4], rtol=0, atol=REOPTIMISED_M
    )
    odometry = database.trajectory(optimised=False)
    assert np.abs(odometry.poses - database.trajectory().poses).max() > REOPTIMISED_M  # the maps were moved


def test_detected_by_its_content_not_its_name(tmp_path):
    renamed = tmp_path / "run.txt"
    shutil.copy(ROS_RULE, renamed)
    assert detect_format(renamed) is TrajectoryFormat.RTABMAP
    assert len(read_trajectory(renamed)[0]) == 7


def broken(tmp_path: Path, change: str) -> Path:
    path = tmp_path / "rtabmap.db"
    shutil.copy(TOOL_RULE, path)
    with sqlite3.connect(path) as raw:
        raw.execute(change, (NOT_ZLIB,) if "?" in change else ())
    return path


@pytest.mark.parametrize(
    "change, problem",
    [
        ("DROP TABLE Node", "not an RTAB-Map database (no Node table)"),
        ("DELETE FROM Node", "holds no node"),
        ("UPDATE Node SET pose = zeroblob(8) WHERE id = 3", "node 3: no pose"),
        ("UPDATE Statistics SET data = ? WHERE id = 2", "statistics of node 2: damaged compressed data"),
        ("UPDATE Admin SET opt_poses = ?", "Admin.opt_poses: damaged compressed data"),
    ],
)
def test_a_damaged_database_is_refused_naming_it(tmp_path, change, problem):
    path = broken(tmp_path, change)
    with pytest.raises(InputError, match=re.escape(problem)) as error:
        read_trajectory(path)
    assert str(error.value).startswith(f"{path}: ")


def test_a_file_that_is_not_a_database(tmp_path):
    truncated = tmp_path / "truncated.db"
    truncated.write_bytes(TOOL_RULE.read_bytes()[:4096])
    with pytest.raises(InputError, match=f"{truncated}: not a readable RTAB-Map database"):
        read_trajectory(truncated)
    text = tmp_path / "poses.db"
    text.write_text("1 0 0 0 0 0 0 1\n")
    with pytest.raises(InputError, match=f"{text}: not an RTAB-Map database \\(not a SQLite file\\)"):
        read_trajectory(text, "rtabmap")
    with sqlite3.connect(tmp_path / "other.db") as other:
        other.execute("CREATE TABLE notes (text)")
    with pytest.raises(InputError, match="no Admin, Link, Node table"):
        read_trajectory(tmp_path / "other.db")
