"""The report's per-pipeline block, its envelope and strict JSON output."""

import dataclasses
import json
from importlib import metadata

import numpy as np
import pytest
from fixtures_eval import TUM_RPY, perturbed

from viewer_slam.dataset.sources import open_source
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.pipelines.run import PipelineRun
from viewer_slam.runs.run_report import build_report, pipeline_report, write_report
from viewer_slam.runs.scoring import evaluate_run

PIPELINE_KEYS = {
    "source",
    "frames_with_pose",
    "alignment",
    "ate",
    "ate_segments",
    "rpe",
    "coverage",
    "penalized_ate",
    "odometry_ate",
    "node_ate",
    "loop_closures",
    "edges",
    "edges_by_detection",
    "keyframes",
    "tracking_lost",
    "timing",
    "parameters",
}
STATS_KEYS = {"rmse", "mean", "median", "std", "min", "max", "n"}


@pytest.fixture(scope="module")
def sequence():
    return open_source(TUM_RPY)


def finished_run(sequence) -> PipelineRun:
    groundtruth_poses, _ = sequence.groundtruth_at(sequence.timestamps[:60])
    run = PipelineRun(
        pipeline="rgbdslam",
        parameters={"predecessor_candidates": 4, "ratio": float("nan")},
        seed=0,
        frames=87,
        trajectory=perturbed(Trajectory(sequence.timestamps[:60], groundtruth_poses), 1),
        odometry=perturbed(Trajectory(sequence.timestamps[:60], groundtruth_poses), 2),
        frame_indices=np.arange(60),
        keyframes=9,
        loop_closures_accepted=2,
        loop_closures_rejected=5,
        tracking_lost=[{"frame": 60, "timestamp": np.float64(sequence.timestamps[60]), "reason": "too few inliers"}],
        stage_ms_total={"features": 870.0, "ransac": 174.0},
        total_s=2.9,
    )
    return run


def test_pipeline_block_has_exactly_the_documented_keys(sequence):
    run = finished_run(sequence)
    evaluation = evaluate(sequence.groundtruth, run.trajectory)
    odometry = evaluate(sequence.groundtruth, run.odometry)
    block = pipeline_report(run, evaluation, odometry)
    assert set(block) == PIPELINE_KEYS
    assert (
        block["source"] == "pipeline"
        and pipeline_report(dataclasses.replace(run, source="estimate"), None, None)["source"] == "estimate"
    )
    assert block["frames_with_pose"] == 60
    assert block["alignment"] == "rigid"
    assert set(block["ate"]) == set(block["ate_segments"]) == set(block["penalized_ate"]) == STATS_KEYS
    assert set(block["odometry_ate"]) == STATS_KEYS
    assert set(block["rpe"]) == {"trans", "rot", "delta", "delta_unit", "mode"} and block["rpe"]["mode"] == "delta"
    assert set(block["rpe"]["trans"]) == set(block["rpe"]["rot"]) == STATS_KEYS
    assert block["odometry_ate"] == odometry.ate.stats()
    assert block["loop_closures"] == {"accepted": 2, "rejected": 5}
    assert block["keyframes"] == 9
    assert block["timing"] == {"total_s": 2.9, "fps": 87 / 2.9, "per_stage_ms": {"features": 10.0, "ransac": 2.0}}
    # The estimate stops at frame 59 of 87: the rest of the groundtruth time is lost; the
    # groundtruth recorded before the first frame is not.
    assert block["coverage"]["ratio"] < 0.8
    assert block["coverage"]["lost_intervals"] == [[sequence.timestamps[59], sequence.groundtruth.timestamps[-1]]]


def test_without_groundtruth_the_metric_blocks_are_null(sequence):
    block = pipeline_report(finished_run(sequence), None, None)
    assert set(block) == PIPELINE_KEYS
    metric_keys = ("alignment", "ate", "ate_segments", "rpe", "coverage", "penalized_ate", "odometry_ate", "node_ate")
    assert [block[key] for key in metric_keys] == [None] * len(metric_keys)


def test_report_envelope_and_strict_json(sequence, tmp_path):
    run = finished_run(sequence)
    block = pipeline_report(run, evaluate(sequence.groundtruth, run.trajectory), None)
    report = build_report(sequence, {"rgbdslam": block}, interrupted=False)
    assert report["sequence"] == {
        "name": "rgbd_dataset_freiburg1_rpy",
        "path": str(TUM_RPY),
        "frames": 87,
        "duration_s": sequence.duration_s,
    }
    assert report["interrupted"] is False
    assert set(report["versions"]) == {"viewslam", "rerun", "opencv", "gtsam", "open3d"}
    assert report["versions"]["viewslam"] == metadata.version("viewer-slam")
    assert report["versions"]["gtsam"] == metadata.version("gtsam")

    write_report(tmp_path / "report.json", report)
    text = (tmp_path / "report.json").read_text()

    def refuse(constant):
        raise AssertionError(f"non-standard JSON constant {constant}")

    parsed = json.loads(text, parse_constant=refuse)
    assert parsed["pipelines"]["rgbdslam"]["parameters"] == {"predecessor_candidates": 4, "ratio": None}
    assert parsed["pipelines"]["rgbdslam"]["tracking_lost"][0]["timestamp"] == float(sequence.timestamps[60])
    write_report(tmp_path / "again.json", report)
    assert (tmp_path / "again.json").read_text() == text


def test_a_run_is_covered_over_the_frames_it_processed(sequence):
    run = finished_run(sequence)
    evaluation, odometry = evaluate_run(sequence.groundtruth, run, sequence.timestamps[:70])
    assert evaluation.coverage.span == (sequence.timestamps[0], sequence.timestamps[69], "processed frames")
    assert evaluation.coverage.lost_intervals == [(sequence.timestamps[59], sequence.timestamps[69])]
    block = pipeline_report(run, evaluation, odometry)
    assert block["coverage"]["span"] == {
        "start": sequence.timestamps[0],
        "end": sequence.timestamps[69],
        "rule": "processed frames",
    }
    assert block["ate_segments"] == evaluation.segment_ate.stats() and block["alignment"] == "rigid"
