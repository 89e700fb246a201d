"""Scoring and counting as the real RTAB-Map 0.23.8 does, checked against its own outputs
(../shared/data/reference/rtabmap-0.23.8: its poses, links and the figures it computed)."""

import csv
import json

import numpy as np
import pytest
from fixtures_eval import SHARED_DATA

from viewer_slam.dataset.sources import open_source
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.trajectory import read_tum
from viewer_slam.pipelines.edges import EdgeClassifier
from viewer_slam.pipelines.events import GraphEdge, KeyframeAdded, TrajectoryFinal
from viewer_slam.pipelines.run import PipelineRun
from viewer_slam.runs.scoring import evaluate_run

REFERENCE = SHARED_DATA / "reference" / "rtabmap-0.23.8"
PER_FRAME = REFERENCE / "rgbd_dataset_freiburg1_rpy_200-perframe"
DEFAULT = REFERENCE / "rgbd_dataset_freiburg1_rpy_200-default"
TUM_200 = SHARED_DATA / "tum" / "rgbd_dataset_freiburg1_rpy_200"

pytestmark = pytest.mark.skipif(not PER_FRAME.is_dir() or not TUM_200.is_dir(), reason="no reference runs")


def test_node_ate_scores_the_nodes_as_the_original_exports_them():
    """A run whose nodes are the original's 7 default-mode nodes, among poses for every frame:
    node_ate is the ATE of those 7 poses alone, the figure the original computed for its file."""
    sequence = open_source(TUM_200)
    nodes = read_tum(DEFAULT / "poses_tum.txt")
    stamps = np.asarray(sequence.timestamps)
    node_frames = [int(np.argmin(np.abs(stamps - t))) for t in nodes.timestamps]
    poses = np.repeat(np.eye(4)[None], len(stamps), axis=0)
    poses[:, 0, 3] = np.arange(len(stamps))  # every other frame far off: must not count
    poses[node_frames] = nodes.poses
    run = PipelineRun("rtabmap", {}, 0)
    for frame in node_frames:
        run.observe(KeyframeAdded(frame, frame, stamps[frame], poses[frame]))
    run.observe(TrajectoryFinal(np.arange(len(stamps)), stamps, poses, poses))
    scores, _ = evaluate_run(sequence.groundtruth, run, stamps)
    expected = json.loads((DEFAULT / "summary.json").read_text())["ate_tool_poses"]
    assert scores.node_ate.stats()["n"] == expected["n_matched"] == 7
    assert scores.node_ate.stats()["rmse"] == pytest.approx(expected["rmse"], abs=1e-5)


def test_odometry_ate_of_the_original_matches_its_own_figure():
    sequence = open_source(TUM_200)
    expected = json.loads((PER_FRAME / "summary.json").read_text())["ate_db_odom_poses"]["rmse"]
    assert evaluate(sequence.groundtruth, read_tum(PER_FRAME / "db_poses_odom_tum.txt")).ate.stats()[
        "rmse"
    ] == pytest.approx(expected, abs=1e-5)


def test_links_counted_by_detection_as_the_original_counts_them():
    """The original's 200-frame per-frame links replayed as edges: edges_by_detection gives its
    75 global loops and 105 proximity links, while the one rule of edge kinds calls none of them
    a loop (all within 5 s on these 6.6 s)."""
    with open(PER_FRAME / "nodes.csv", newline="") as file:
        stamp = {int(row["node_id"]): float(row["stamp"]) for row in csv.DictReader(file)}
    classifier = EdgeClassifier()
    for node in sorted(stamp):
        classifier.add_node(node, stamp[node])
    run = PipelineRun("rtabmap", {}, 0)
    detection = {"neighbor": "odometry", "global_loop": "appearance", "local_space": "proximity"}
    with open(PER_FRAME / "links.csv", newline="") as file:
        for link in csv.DictReader(file):
            a, b = int(link["from_id"]), int(link["to_id"])
            run.observe(
                GraphEdge(max(a, b) - 1, a, b, True, "", classifier.kind(a, b), detection=detection[link["type_name"]])
            )
    assert run.edges_by_detection == {
        "odometry": {"accepted": 199, "rejected": 0},
        "appearance": {"accepted": 75, "rejected": 0},
        "proximity": {"accepted": 105, "rejected": 0},
    }
    assert run.loop_closures_accepted == 0 and run.edges["loop"] == 0
