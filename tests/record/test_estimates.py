"""`viewslam record --estimate`: other systems' trajectories recorded as runs beside a pipeline.

Two estimates are made from a short synthetic scenario's groundtruth with noise added: a
TUM file with a gap in the middle, a dropped pose and a quit before the end, and a KITTI
file (one pose per frame of the sequence, no gaps). The expected losses and coverage are
worked out here from the gaps made, with the rule docs/metrics.md states (a stretch
without poses longer than three frame periods, and at least 0.1 s, is lost). A ROS bag
written from the shared TUM excerpt records with its topics and groundtruth given as flags.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from bag_writer import write_tum_bag
from fixtures_eval import TUM_RPY, tum_excerpt
from rerun.chunk import RrdReader

from viewer_slam import palette
from viewer_slam.cli import main
from viewer_slam.dataset.sources import open_source
from viewer_slam.dataset.synth import cached_scenario
from viewer_slam.geometry.trajectory import Trajectory, read_tum, write_tum
from viewer_slam.record.outputs import output_path
from viewer_slam.rerun_adapter import layout

pytestmark = pytest.mark.slow

BIN = Path(sys.executable).parent
FRAMES = 40  # processed, of the scenario's 90 (rendered as the other record tests render it)
NOISE_M = 0.01
GAP = range(12, 22)  # frames without a pose in the TUM estimate: 11 periods, lost
DROPPED = 30  # a single missing pose: 2 periods, not lost
LAST_POSE = 35  # then it quits: 4 periods to the last processed frame, lost


@pytest.fixture(scope="module")
def scenario() -> Path:
    return cached_scenario("360_kidnap", frames=90, resolution=(320, 240))


def noisy(poses: np.ndarray, seed: int) -> np.ndarray:
    noisy = poses.copy()
    noisy[:, :3, 3] += np.random.default_rng(seed).normal(0.0, NOISE_M, (len(poses), 3))
    return noisy


def write_kitti(path: Path, poses: np.ndarray) -> None:
    path.write_text("".join(" ".join(f"{value:.9f}" for value in pose[:3].ravel()) + "\n" for pose in poses))


@pytest.fixture(scope="module")
def recorded(scenario, tmp_path_factory):
    folder = tmp_path_factory.mktemp("estimates")
    stamps = open_source(scenario).timestamps
    poses, covered = open_source(scenario).groundtruth_at(stamps)
    assert covered.all()
    posed = [k for k in range(LAST_POSE + 1) if k not in GAP and k != DROPPED]
    tum = Trajectory(stamps[posed], noisy(poses[posed], seed=1))
    write_tum(folder / "orb.txt", tum)
    write_kitti(folder / "droid.kitti", noisy(poses, seed=2))
    out = folder / "run.rrd"
    command = [
        "record",
        str(scenario),
        "--pipeline",
        "rgbdslam",
        "--max-frames",
        str(FRAMES),
        "--out",
        str(out),
        "--estimate",
        f"orb={folder / 'orb.txt'}",
        "--estimate",
        f"droid={folder / 'droid.kitti'}",
    ]
    return command, stamps[:FRAMES], tum, out


@pytest.fixture(scope="module")
def report(recorded):
    command, _, _, out = recorded
    result = subprocess.run([BIN / "viewslam", *command], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return json.loads(out.with_suffix(".json").read_text()), result


def test_the_report_has_a_block_per_run_marked_with_its_source(report, recorded):
    blocks = report[0]["pipelines"]
    assert list(blocks) == ["rgbdslam", "orb", "droid"]
    assert blocks["rgbdslam"]["source"] == "pipeline"
    folder = recorded[3].parent
    assert blocks["orb"]["source"] == blocks["droid"]["source"] == "estimate"
    assert blocks["orb"]["parameters"] == {"file": str(folder / "orb.txt"), "format": "tum"}
    assert blocks["droid"]["parameters"] == {"file": str(folder / "droid.kitti"), "format": "kitti"}
    assert set(blocks["orb"]) == set(blocks["rgbdslam"]) and set(blocks["droid"]) == set(blocks["rgbdslam"])


def test_losses_and_coverage_follow_the_gaps_made(report, recorded):
    _, stamps, tum, _ = recorded
    orb = report[0]["pipelines"]["orb"]
    lost = [(stamps[GAP.start - 1], stamps[GAP.stop]), (stamps[LAST_POSE], stamps[-1])]
    np.testing.assert_allclose(orb["coverage"]["lost_intervals"], lost, rtol=0, atol=1e-6)  # TUM's 6 decimals
    span = stamps[-1] - stamps[0]
    assert orb["coverage"]["ratio"] == pytest.approx(1 - sum(end - start for start, end in lost) / span, abs=1e-5)
    assert [entry["frame"] for entry in orb["tracking_lost"]] == [GAP.start, LAST_POSE + 1]
    assert orb["frames_with_pose"] == len(tum) and orb["ate"]["n"] == len(tum)
    # The penalty holds the last pose through the lost time, so it can only add error.
    assert orb["penalized_ate"]["n"] > orb["ate"]["n"] and orb["penalized_ate"]["rmse"] > orb["ate"]["rmse"]
    droid = report[0]["pipelines"]["droid"]
    assert (droid["coverage"]["ratio"], droid["coverage"]["lost_intervals"]) == (1.0, []) and droid[
        "tracking_lost"
    ] == []
    assert droid["frames_with_pose"] == FRAMES
    for block in (orb, droid):  # noise of NOISE_M per axis: about sqrt(3) NOISE_M after a rigid alignment
        assert 0.6 * np.sqrt(3) * NOISE_M < block["ate"]["rmse"] < 1.3 * np.sqrt(3) * NOISE_M


def test_stderr_says_which_format_was_read_and_the_summary_lists_every_run(report, recorded):
    result, folder = report[1], recorded[3].parent
    assert f"estimate orb: {folder / 'orb.txt'} read as tum (detected)" in result.stderr
    assert f"estimate droid: {folder / 'droid.kitti'} read as kitti (detected)" in result.stderr
    rows = {}
    for line in result.stdout.splitlines():
        if line.strip():
            rows.setdefault(line.split()[0], line.split())  # the table's row comes before the loss lines
    assert {"rgbdslam", "orb", "droid"} <= set(rows)
    # A replayed file has no loop closures or processing rate of its own: dashes, not zeros.
    assert rows["orb"][-2:] == rows["droid"][-2:] == ["—", "—"] and rows["rgbdslam"][-1] != "—"


def test_each_estimate_is_a_run_in_the_recording_and_its_trajectory_file(report, recorded):
    _, stamps, tum, out = recorded
    entities = {line.split()[0] for line in RrdReader(out).store().summary().splitlines()}
    for name in ("orb", "droid"):
        expected = {f"/{path}" for path in (layout.world(name), layout.camera(name), layout.trajectory(name))}
        expected |= {f"/{layout.metric(name, series)}" for series in ("ate", "rpe_trans", "tracking_state")}
        assert sorted(expected - entities) == [], name
    written = read_tum(out.with_name("run.orb.txt"))
    np.testing.assert_allclose(written.timestamps, tum.timestamps, rtol=0, atol=1e-6)
    np.testing.assert_allclose(written.poses, tum.poses, rtol=0, atol=1e-5)  # TUM keeps 6 decimals
    assert len(read_tum(out.with_name("run.droid.txt"))) == FRAMES


def test_an_estimate_has_no_tracker_count_series_and_the_pipeline_has_them(report, recorded):
    """An estimate measures no features, matches or inliers: no series (not zeros) and none in the plot."""
    out = recorded[3]
    logged = {}
    for chunk in RrdReader(out).stream().to_chunks():
        logged.setdefault(chunk.entity_path, []).append(chunk.num_rows)
    for series in ("features", "matches", "inliers"):
        assert sum(logged.get(f"/{layout.metric('rgbdslam', series)}", [])) > FRAMES, series  # style + a row a frame
        for name in ("orb", "droid"):
            assert f"/{layout.metric(name, series)}" not in logged, (name, series)
    queries = [
        query
        for chunk in RrdReader(out).stream(store=RrdReader(out).blueprints()[0]).to_chunks()
        if chunk.entity_path.endswith("/ViewContents")
        for query in chunk.to_record_batch().column("ViewContents:query").to_pylist()[0]
    ]
    plotted = [query for query in queries if query.endswith(("/features", "/inliers"))]
    assert sorted(plotted) == [f"/{layout.metric('rgbdslam', 'features')}", f"/{layout.metric('rgbdslam', 'inliers')}"]


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="xvfb-run is not installed (Debian package xvfb)")
def test_the_viewer_renders_the_recording_with_the_estimates(report, recorded, tmp_path):
    shot = tmp_path / "shot.png"
    subprocess.run(
        ["xvfb-run", "-a", BIN / "rerun", "--screenshot-to", shot, "--window-size", "1600x900", recorded[3]],
        capture_output=True,
        timeout=180,
        check=True,
    )
    image = cv2.cvtColor(cv2.imread(str(shot)), cv2.COLOR_BGR2RGB)
    assert image.shape[0] >= 900 and image.shape[1] >= 1600
    assert image.std() > 20 and len(np.unique(image.reshape(-1, 3) // 8, axis=0)) > 500
    for position, name in enumerate(report[0]["pipelines"]):  # each run's colour is drawn
        distance = np.abs(image.astype(int) - palette.run_colour(name, position).rgb).sum(axis=2)
        assert np.count_nonzero(distance < 40) > 200, name


def test_estimates_alone_run_no_pipeline(scenario, recorded, tmp_path):
    folder = recorded[3].parent
    out = tmp_path / "alone.rrd"
    assert (
        main(
            [
                "record",
                str(scenario),
                "--max-frames",
                "10",
                "--out",
                str(out),
                "--quiet",
                "--estimate",
                f"droid={folder / 'droid.kitti'}",
                "--format",
                "kitti",
            ]
        )
        == 0
    )
    blocks = json.loads(out.with_suffix(".json").read_text())["pipelines"]
    assert list(blocks) == ["droid"] and blocks["droid"]["frames_with_pose"] == 10


def test_a_pipelines_own_trajectory_replayed_scores_as_the_pipeline(scenario, report, recorded, tmp_path):
    out = tmp_path / "again.rrd"
    assert (
        main(
            [
                "record",
                str(scenario),
                "--max-frames",
                str(FRAMES),
                "--out",
                str(out),
                "--quiet",
                "--estimate",
                f"again={recorded[3].with_name('run.rgbdslam.txt')}",
            ]
        )
        == 0
    )
    again = json.loads(out.with_suffix(".json").read_text())["pipelines"]["again"]
    pipeline = report[0]["pipelines"]["rgbdslam"]
    assert again["frames_with_pose"] == pipeline["frames_with_pose"] > 0
    for metric in ("ate", "penalized_ate"):  # the file keeps 6 decimals
        assert again[metric]["rmse"] == pytest.approx(pipeline[metric]["rmse"], abs=1e-5), metric
    assert again["coverage"]["ratio"] == pytest.approx(pipeline["coverage"]["ratio"], abs=1e-6)


@pytest.mark.parametrize(
    ("sequence", "expected"),
    [
        ("data/rgbd_dataset_freiburg1_xyz.bag", "recordings/rgbd_dataset_freiburg1_xyz.rrd"),
        ("data/ros2_bag/", "recordings/ros2_bag.rrd"),
        ("data/rgbd_dataset_freiburg1_xyz", "recordings/rgbd_dataset_freiburg1_xyz.rrd"),
        ("fr1/xyz", "recordings/xyz.rrd"),
    ],
)
def test_a_bag_is_recorded_under_its_stem(sequence, expected):
    assert output_path(sequence, None) == Path(expected)


@pytest.mark.skipif(not TUM_RPY.is_dir(), reason="shared TUM excerpt not present")
def test_a_bag_records_with_its_topics_and_groundtruth_given_on_the_command_line(tmp_path, monkeypatch, capfd):
    excerpt = tum_excerpt(tmp_path / "rgbd_dataset_freiburg1_rpy", frames=3)
    bag = write_tum_bag(excerpt, tmp_path / "rgbd_dataset_freiburg1_rpy.bag", ros=1)
    stamps = open_source(excerpt).timestamps
    groundtruth = open_source(excerpt).groundtruth
    short = groundtruth.subset(groundtruth.timestamps <= stamps[1])  # covers the first two frames only
    write_tum(tmp_path / "short.txt", short)
    monkeypatch.chdir(tmp_path)
    topics = [
        "--rgb-topic",
        "/camera/rgb/image_color",
        "--depth-topic",
        "/camera/depth/image",
        "--camera-info-topic",
        "/camera/rgb/camera_info",
    ]
    assert main(["record", str(bag), "--pipeline", "rgbdslam", *topics, "--groundtruth", "short.txt", "--quiet"]) == 0
    report = json.loads((tmp_path / "recordings" / "rgbd_dataset_freiburg1_rpy.json").read_text())
    assert (tmp_path / "recordings" / "rgbd_dataset_freiburg1_rpy.rrd").is_file()
    block = report["pipelines"]["rgbdslam"]
    assert block["frames_with_pose"] == 3 and block["ate"]["n"] == 2  # the third frame is past the file's end
    capfd.readouterr()
    assert main(["record", str(bag), "--rgb-topic", "/camera/nothing", "--quiet"]) == 2
    error = capfd.readouterr().err
    assert error.count("\n") == 1 and "--rgb-topic" in error and "/camera/nothing" in error
