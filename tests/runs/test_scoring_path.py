"""One scoring path for trajectory files: `evaluate`, `record --groundtruth` and `study` read them the
same way (a groundtruth file in TUM or EuRoC, or a ROS bag of poses; estimates in any format or a
bag's pose topic) and give the same numbers."""

import json

import numpy as np
import pytest
from bag_writer import BagWriter, write_poses
from scipy.spatial.transform import Rotation
from trajectory_writers import write_euroc

from viewer_slam.cli import main
from viewer_slam.geometry.se3 import make_pose
from viewer_slam.geometry.trajectory import Trajectory, write_tum
from viewer_slam.runs.trajectory_files import ScoringOptions, read_estimate_file, read_groundtruth, score_estimate
from viewer_slam.study.replay import score_run

STAMPS = 5 + np.arange(40) * 0.05


def circle(noise: float, seed: int) -> np.ndarray:
    """A turning walk of 40 poses, with ``noise`` metres of normal noise on each position."""
    poses = np.array(
        [
            make_pose(
                Rotation.from_rotvec(np.array([0.0, 0.04 * k, 0.0])).as_matrix(), np.array([0.05 * k, 0.0, 0.01 * k])
            )
            for k in range(len(STAMPS))
        ]
    )
    poses[:, :3, 3] += np.random.default_rng(seed).normal(0.0, noise, (len(STAMPS), 3))
    return poses


@pytest.fixture
def files(tmp_path):
    """The groundtruth as a TUM file, a EuRoC file and a ROS bag of poses; the estimate as a TUM
    file and as a ROS bag's pose topic (the estimate stops 10 poses before the groundtruth)."""
    truth, estimate = Trajectory(STAMPS, circle(0.0, 0)), Trajectory(STAMPS[:30], circle(0.02, 1)[:30])
    write_tum(tmp_path / "truth.txt", truth)
    write_euroc(tmp_path / "truth.csv", truth)
    write_tum(tmp_path / "estimate.txt", estimate)
    for name, topic, trajectory in (("truth.bag", "/mocap/pose", truth), ("estimate.bag", "/slam/pose", estimate)):
        with BagWriter(tmp_path / name, 1) as bag:
            write_poses(bag, topic, trajectory.poses, step_ns=50_000_000)
    return tmp_path


def evaluated(groundtruth, estimate, out) -> dict:
    assert main(["evaluate", str(groundtruth), str(estimate), "--json", str(out)]) == 0
    return json.loads(out.read_text())


def recorded(groundtruth, estimate, out) -> dict:
    assert (
        main(
            [
                "record",
                "--groundtruth",
                str(groundtruth),
                "--estimate",
                f"slam={estimate}",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    return json.loads(out.with_suffix(".json").read_text())["pipelines"]["slam"]


@pytest.mark.parametrize("groundtruth", ["truth.txt", "truth.csv", "truth.bag"])
@pytest.mark.parametrize("estimate", ["estimate.txt", "estimate.bag"])
def test_evaluate_and_record_accept_the_same_inputs_and_agree(files, groundtruth, estimate, capsys):
    scores = evaluated(files / groundtruth, files / estimate, files / "scores.json")
    block = recorded(files / groundtruth, files / estimate, files / "run.rrd")
    reference = evaluated(files / "truth.txt", files / "estimate.txt", files / "reference.json")
    capsys.readouterr()
    for key in ("ate", "penalized_ate"):
        assert scores[key] == block[key]
        # the same poses, written as text (TUM, EuRoC) or as doubles (a bag): the same scores to the text's digits
        assert scores[key]["rmse"] == pytest.approx(reference[key]["rmse"], rel=1e-5)
    assert scores["ate"]["n"] == 30 and 0.01 < scores["ate"]["rmse"] < 0.05  # 2 cm of noise per axis
    assert scores["coverage"]["ratio"] == block["coverage"]["ratio"] < 0.8  # it stopped 10 poses early


def test_study_scores_a_run_as_evaluate_does_with_tum_rpe(files, capsys):
    assert (
        main(
            [
                "evaluate",
                str(files / "truth.txt"),
                str(files / "estimate.txt"),
                "--rpe-mode",
                "tum",
                "--json",
                str(files / "tum.json"),
            ]
        )
        == 0
    )
    capsys.readouterr()
    scores = json.loads((files / "tum.json").read_text())
    study = score_run(files / "truth.txt", files / "estimate.txt")
    assert study["ate_rmse"] == scores["ate"]["rmse"] and study["ate_pairs"] == scores["ate"]["n"] == 30
    assert study["rpe_trans_rmse"] == scores["rpe"]["trans"]["rmse"]
    assert study["coverage"] == scores["coverage"]["ratio"]


def test_one_scoring_call_reads_what_the_commands_read(files):
    groundtruth = read_groundtruth(files / "truth.bag")
    for name in ("estimate.txt", "estimate.bag"):
        evaluation = score_estimate(groundtruth, read_estimate_file(files / name), ScoringOptions())
        assert len(evaluation.pairs[0]) == 30
    assert read_estimate_file(files / "estimate.bag").format == "bag"
