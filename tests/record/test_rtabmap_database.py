"""`viewslam record --groundtruth GT --estimate NAME=rtabmap.db`: the real RTAB-Map's run as a run.

The database is RTAB-Map 0.23.8's own run of the synthetic 360_kidnap under its dataset
tool's rule (``tests/data/rtabmap/SOURCE.md``): four maps, one after each covering of the
sensor, joined by loop closures and proximity links. Its ATE over the nodes is worked out
here from its poses with Horn's method, independently of viewslam's evaluation.
"""

import json
import sqlite3
from pathlib import Path

import numpy as np
from rerun.chunk import RrdReader

from viewer_slam.cli import main
from viewer_slam.geometry.rtabmap_database import read_rtabmap_database
from viewer_slam.geometry.trajectory import read_tum

DATA = Path(__file__).resolve().parents[1] / "data" / "rtabmap"
DATABASE = DATA / "360_kidnap-toolrule.db"
GROUNDTRUTH = DATA / "360_kidnap.groundtruth.txt"


def horn_rmse(estimate: np.ndarray, reference: np.ndarray) -> float:
    """Translation RMSE after the rigid alignment of ``estimate`` onto ``reference`` (both (N, 3))."""
    mean_e, mean_r = estimate.mean(0), reference.mean(0)
    u, _, vt = np.linalg.svd((reference - mean_r).T @ (estimate - mean_e))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    aligned = (estimate - mean_e) @ (u @ d @ vt).T + mean_r
    return float(np.sqrt(((aligned - reference) ** 2).sum(1).mean()))


def test_its_maps_closures_and_losses_are_the_databases(tmp_path, capsys):
    out = tmp_path / "original.rrd"
    assert (
        main(
            [
                "record",
                "--groundtruth",
                str(GROUNDTRUTH),
                "--estimate",
                f"rtabmap={DATABASE}",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    block = json.loads(out.with_suffix(".json").read_text())["pipelines"]["rtabmap"]
    with sqlite3.connect(DATABASE) as raw:
        nodes = raw.execute("SELECT count(*) FROM Node WHERE id > 0").fetchone()[0]
        maps = raw.execute("SELECT count(DISTINCT map_id) FROM Node WHERE id > 0").fetchone()[0]
        links = dict(raw.execute("SELECT type, count(*) / 2 FROM Link GROUP BY type").fetchall())
    assert block["parameters"]["format"] == "rtabmap"
    assert block["keyframes"] == nodes
    assert block["edges_by_detection"]["appearance"]["accepted"] == links[1]
    assert block["edges_by_detection"]["proximity"]["accepted"] == links[2]
    assert len(block["tracking_lost"]) == maps - 1  # a loss before every new map
    database = read_rtabmap_database(DATABASE)
    groundtruth = read_tum(GROUNDTRUTH)
    nearest = [int(np.argmin(np.abs(groundtruth.timestamps - node.stamp))) for node in database.nodes]
    expected = horn_rmse(database.trajectory().positions, groundtruth.positions[nearest])
    assert abs(block["node_ate"]["rmse"] - expected) < 1e-9
    assert abs(block["ate"]["rmse"] - expected) < 1e-9
    lines = log_lines(out, "log/rtabmap")
    assert sum(line.startswith("rtabmap: new map ") for line in lines) == maps - 1
    assert sum(" by appearance " in line and "loop closure" in line for line in lines) == links[1]
    assert static_segments(out, "world/rtabmap/loop_closures") == links[1] + links[2]


def log_lines(path: Path, entity: str) -> list[str]:
    found = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == f"/{entity}":
            batch = chunk.to_record_batch()
            column = next(name for name in batch.schema.names if name.endswith(":text"))
            found += [text for row in batch.column(column).to_pylist() for text in (row or [])]
    return found


def static_segments(path: Path, entity: str) -> int:
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == f"/{entity}" and chunk.is_static:
            batch = chunk.to_record_batch()
            column = next(name for name in batch.schema.names if name.endswith(":strips"))
            return len(batch.column(column).to_pylist()[-1])
    return 0
