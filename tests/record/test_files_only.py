"""`viewslam record --groundtruth FILE --estimate NAME=FILE ...`: a recording of trajectory files alone.

The study's fr2/360_kidnap runs (the shared copy of the author's repository) are recorded
and read back: every pose's error in the recording is the one `evaluate` gives, the RTAB-Map
run's lost interval runs from 14.2 s after its first pose to the groundtruth's end. A small synthetic pair of
files (a TUM estimate with a gap and a quit, an EuRoC one with none) checks the timelines
against losses worked out here from the gaps made. Bad input is one line naming the option
or file, exit code 2.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from fixtures_eval import SHARED_DATA, perturbed, random_walk
from rerun.chunk import RrdReader

from viewer_slam import palette
from viewer_slam.cli import main
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.se3 import pose_to_tq
from viewer_slam.geometry.trajectory import read_tum, write_tum
from viewer_slam.rerun_adapter import layout
from viewer_slam.schemas import validator

KIDNAP = SHARED_DATA / "study_kasar2018" / "freiburg2_360_kidnap"
RUNS = {"rgbdslam_v2": KIDNAP / "rgbd" / "rgbd_poses.txt", "rtabmap": KIDNAP / "rtab" / "rtabmap_poses.txt"}
GROUNDTRUTH = KIDNAP / "rgbd" / "groundtruth.txt"
needs_study = pytest.mark.skipif(not KIDNAP.is_dir(), reason="the study's shared runs are not present")

GT_RATE_HZ = 90.0
EVERY = 3  # the estimates have a pose at every third groundtruth pose: 30 Hz
GAP = (180, 270)  # groundtruth poses 2 s to 3 s: no pose of the TUM estimate
QUIT = 450  # ... and none from 5 s on (the groundtruth runs to 600 / 90 = 6.7 s)


def rows(path, entity: str, column: str) -> list[tuple[int, float, object]]:
    """(frame, time in seconds, value) of every row logged at ``entity`` on the timelines with ``column`` set."""
    found = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path != f"/{entity}" or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        times = [
            value.timestamp() if hasattr(value, "timestamp") else value / 1e9
            for value in batch.column("time").to_pylist()
        ]
        values = batch.column(column).to_pylist() if column in batch.schema.names else [None] * batch.num_rows
        found += [
            (frame, time, value)
            for frame, time, value in zip(batch.column("frame").to_pylist(), times, values)
            if value is not None
        ]
    return sorted(found, key=lambda row: (row[0], row[1]))


def static_value(path, entity: str, column: str):
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == f"/{entity}" and chunk.is_static:
            batch = chunk.to_record_batch()
            if column in batch.schema.names:
                return batch.column(column).to_pylist()[-1]
    raise AssertionError(f"no static {column} at {entity}")


def record(capsys, *args) -> tuple[int, str]:
    code = main(["record", *map(str, args)])
    return code, capsys.readouterr().err


@pytest.fixture(scope="module")
def kidnap(tmp_path_factory):
    out = tmp_path_factory.mktemp("kidnap") / "kidnap.rrd"
    estimates = [arg for name, file in RUNS.items() for arg in ("--estimate", f"{name}={file}")]
    assert main(["record", "--groundtruth", str(GROUNDTRUTH), *estimates, "--out", str(out), "--quiet"]) == 0
    groundtruth = read_tum(GROUNDTRUTH)
    evaluations = {name: evaluate(groundtruth, read_tum(file, in_order=True)) for name, file in RUNS.items()}
    return out, groundtruth, evaluations


@needs_study
def test_the_kidnap_recording_holds_every_entity_of_each_run(kidnap):
    out, _, _ = kidnap
    entities = {line.split()[0] for line in RrdReader(out).store().summary().splitlines()}
    expected = {f"/{layout.GROUNDTRUTH}", f"/{layout.SUMMARY}"}
    for name in RUNS:
        expected |= {
            f"/{path}"
            for path in (
                layout.world(name),
                layout.trajectory(name),
                layout.poses(name),
                layout.correspondences(name),
                layout.camera(name),
                layout.text_log(name),
            )
        }
        expected |= {
            f"/{layout.metric(name, series)}"
            for series in ("ate", "ate_segments", "rpe_trans", "rpe_rot", "coverage", "lost", "tracking_state")
        }
    assert sorted(expected - entities) == []
    assert not any("/matches" in entity or entity.startswith("/camera") for entity in entities)  # no images
    assert len(RrdReader(out).blueprints()) == 1


@needs_study
def test_every_pose_error_in_the_recording_is_evaluates(kidnap):
    out, _, evaluations = kidnap
    for name, evaluation in evaluations.items():
        logged = rows(out, layout.metric(name, "ate"), "Scalars:scalars")
        assert len(logged) == len(evaluation.pairs[0]) == len(evaluation.ate.errors)
        np.testing.assert_allclose([value[0] for _, _, value in logged], evaluation.ate.errors, rtol=1e-12, atol=0)
        np.testing.assert_allclose([time for _, time, _ in logged], evaluation.ate.timestamps, rtol=0, atol=1e-6)
        segments = rows(out, layout.metric(name, "ate_segments"), "Scalars:scalars")
        np.testing.assert_allclose([value[0] for _, _, value in segments], evaluation.segment_ate.errors, rtol=1e-12)
        assert len(rows(out, layout.metric(name, "rpe_trans"), "Scalars:scalars")) == len(evaluation.rpe_trans.errors)
        correspondences = static_value(out, layout.correspondences(name), "LineStrips3D:strips")
        assert len(correspondences) == len(evaluation.pairs[0])


@needs_study
def test_the_poses_are_coloured_by_their_error_on_one_scale(kidnap):
    out, _, evaluations = kidnap
    top = max(evaluation.ate.errors.max() for evaluation in evaluations.values())
    for name, evaluation in evaluations.items():
        colours = np.array(static_value(out, layout.poses(name), "Points3D:colors"), dtype=np.uint32)
        expected = palette.error_colours(evaluation.pose_errors(len(colours)), top).astype(np.uint32)
        np.testing.assert_array_equal(
            colours, (expected[:, 0] << 24) | (expected[:, 1] << 16) | (expected[:, 2] << 8) | 255
        )


@needs_study
def test_rtabmap_is_lost_from_14_2_s_to_the_end_in_the_recording_and_the_report(kidnap):
    out, groundtruth, evaluations = kidnap
    span = evaluations["rtabmap"].coverage.span  # from the run's first pose (the groundtruth starts 0.4 s before)
    start, end = span.start, span.end
    assert end == groundtruth.timestamps[-1]
    band = rows(out, layout.metric("rtabmap", "lost"), "Scalars:scalars")
    assert band[0][1] - start == pytest.approx(14.2, abs=0.05)
    assert band[-1][1] == pytest.approx(end, abs=1e-6) and band[-1][0] == len(groundtruth) - 1
    states = rows(out, layout.metric("rtabmap", "tracking_state"), "StateChange:state")
    assert [state[0] for _, _, state in states] == ["ok", "lost"]
    assert states[1][1] - start == pytest.approx(14.2, abs=0.05)
    lines = [text for _, _, text in rows(out, layout.text_log("rtabmap"), "TextLog:text")]
    assert len(lines) == 1 and lines[0][0].startswith("rtabmap stopped at 14.2 s of 47.7 s")
    report = json.loads(out.with_suffix(".json").read_text())
    validator("report").validate(report)
    block = report["pipelines"]["rtabmap"]
    assert block["source"] == "estimate" and block["coverage"]["ratio"] == pytest.approx(0.299, abs=0.0005)
    assert block["coverage"]["lost_intervals"] == [
        list(interval) for interval in evaluations["rtabmap"].coverage.lost_intervals
    ]
    assert block["ate"]["rmse"] == pytest.approx(evaluations["rtabmap"].ate.stats()["rmse"], rel=1e-12)
    assert report["sequence"]["path"] == str(GROUNDTRUTH) and report["sequence"]["frames"] == len(groundtruth)
    summary = static_value(out, layout.SUMMARY, "TextDocument:text")[0]
    assert "| rtabmap | `rtabmap_poses.txt` | tum | 15 | 15 | 29.9% |" in summary and "14.2 of 47.7 s" in summary
    written = read_tum(out.with_name("kidnap.rtabmap.txt"))
    np.testing.assert_allclose(written.poses, read_tum(RUNS["rtabmap"]).poses, atol=1e-6)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A groundtruth at 90 Hz, a TUM estimate at 30 Hz with a gap and a quit, an EuRoC one at 30 Hz with neither."""
    folder = tmp_path_factory.mktemp("small")
    groundtruth = random_walk(600, seed=5, rate_hz=GT_RATE_HZ)
    write_tum(folder / "groundtruth.txt", groundtruth)
    kept = [k for k in range(0, QUIT + 1, EVERY) if not GAP[0] < k < GAP[1]]
    write_tum(folder / "orb.txt", perturbed(groundtruth, seed=1).subset(kept))
    euroc = perturbed(groundtruth, seed=2).subset(np.arange(0, len(groundtruth), EVERY))
    translations, quaternions = pose_to_tq(euroc.poses)
    (folder / "droid.csv").write_text(
        "#timestamp [ns],tx,ty,tz,qw,qx,qy,qz\n"
        + "".join(
            f"{round(stamp * 1e9)},{t[0]:.9f},{t[1]:.9f},{t[2]:.9f},{q[3]:.9f},{q[0]:.9f},{q[1]:.9f},{q[2]:.9f}\n"
            for stamp, t, q in zip(euroc.timestamps, translations, quaternions)
        )
    )
    return folder, groundtruth


def test_the_losses_follow_the_gaps_made_on_the_groundtruths_frames(capsys, small, tmp_path):
    folder, groundtruth = small
    out = tmp_path / "small.rrd"
    code, err = record(
        capsys,
        "--groundtruth",
        folder / "groundtruth.txt",
        "--estimate",
        f"orb={folder / 'orb.txt'}",
        "--estimate",
        f"droid={folder / 'droid.csv'}",
        "--out",
        out,
    )
    assert code == 0, err
    assert f"estimate droid: {folder / 'droid.csv'} read as euroc (detected)" in err
    stamps = groundtruth.timestamps
    report = json.loads(out.with_suffix(".json").read_text())
    orb, droid = report["pipelines"]["orb"], report["pipelines"]["droid"]
    np.testing.assert_allclose(
        orb["coverage"]["lost_intervals"], [(stamps[GAP[0]], stamps[GAP[1]]), (stamps[QUIT], stamps[-1])], atol=1e-6
    )
    assert [loss["frame"] for loss in orb["tracking_lost"]] == [GAP[0] + 1, QUIT + 1]
    assert droid["coverage"]["lost_intervals"] == [] and droid["tracking_lost"] == []
    assert droid["parameters"] == {"file": str(folder / "droid.csv"), "format": "euroc"}
    # Each pose is on the frame timeline at its groundtruth pose; the lost band fills the gap and the quit.
    ate = rows(out, layout.metric("orb", "ate"), "Scalars:scalars")
    assert [frame for frame, _, _ in ate] == [k for k in range(0, QUIT + 1, EVERY) if not GAP[0] < k < GAP[1]]
    band = [frame for frame, _, _ in rows(out, layout.metric("orb", "lost"), "Scalars:scalars")]
    assert band[0] == GAP[0] and band[-1] == len(stamps) - 1
    assert all(GAP[0] <= frame <= GAP[1] or frame >= QUIT for frame in band)
    assert len(rows(out, layout.metric("droid", "lost"), "Scalars:scalars")) == 0
    lines = [text[0] for _, _, text in rows(out, layout.text_log("orb"), "TextLog:text")]
    assert lines[0].startswith("orb lost at 2.0 s for 1.0 s") and lines[1] == "orb: poses again after 1.0 s"
    assert lines[2].startswith("orb stopped at 5.0 s of 6.7 s")


def test_study_record_writes_the_same_recording_as_record(capsys, small, tmp_path):
    """`study --record` calls the same function: the files-only recording of `record` (checked here on the
    small files through the library, as the study calls it)."""
    from viewer_slam.record.files import record_trajectory_files

    folder, _ = small
    result = record_trajectory_files(
        folder / "groundtruth.txt", [("orb", folder / "orb.txt")], tmp_path / "s.rrd", format="tum", name="a sequence"
    )
    assert result.report["sequence"]["name"] == "a sequence"
    assert result.written == [tmp_path / "s.rrd", tmp_path / "s.json", tmp_path / "s.orb.txt"]


def bad_cases(folder):
    groundtruth, orb = folder / "groundtruth.txt", folder / "orb.txt"
    return {
        "sequence too": (
            [folder, "--groundtruth", groundtruth, "--estimate", f"orb={orb}"],
            f"--groundtruth: only for a ROS bag, and {folder} is not one (without SEQUENCE",
        ),
        "pipeline": (
            ["--groundtruth", groundtruth, "--estimate", f"orb={orb}", "--pipeline", "rgbdslam"],
            "--pipeline: ",
        ),
        "no estimate": (["--groundtruth", groundtruth], f"--groundtruth {groundtruth}: "),
        "max frames": (
            ["--groundtruth", groundtruth, "--estimate", f"orb={orb}", "--max-frames", "5"],
            "--max-frames: ",
        ),
        "topic": (["--groundtruth", groundtruth, "--estimate", f"orb={orb}", "--rgb-topic", "/x"], "--rgb-topic: "),
        "missing groundtruth": (
            ["--groundtruth", folder / "absent.txt", "--estimate", f"orb={orb}"],
            f"{folder / 'absent.txt'}: no such file",
        ),
        "folder groundtruth": (["--groundtruth", folder, "--estimate", f"orb={orb}"], f"{folder}: is a folder"),
        "bad estimate": (
            ["--groundtruth", groundtruth, "--estimate", f"bad={folder / 'bad.txt'}"],
            f"{folder / 'bad.txt'}:2: expected 8 fields",
        ),
        "kitti": (
            ["--groundtruth", groundtruth, "--estimate", f"k={folder / 'poses.kitti'}"],
            f"{folder / 'poses.kitti'}: KITTI poses carry no timestamps",
        ),
        "no overlap": (
            ["--groundtruth", groundtruth, "--estimate", f"late={folder / 'late.txt'}"],
            f"{folder / 'late.txt'}: no temporal overlap",
        ),
        "output is an input": (
            [
                "--groundtruth",
                groundtruth,
                "--estimate",
                f"orb={orb}",
                "--out",
                folder / "x.rrd",
                "--estimate",
                f"x={folder / 'x.orb.txt'}",
            ],
            f"{folder / 'x.orb.txt'}",
        ),
    }


@pytest.mark.parametrize("case", list(bad_cases(SHARED_DATA)))
def test_bad_input_is_one_line_naming_the_option_or_file(capsys, small, tmp_path, case):
    folder = tmp_path / "inputs"
    shutil.copytree(small[0], folder)
    (folder / "bad.txt").write_text("1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 1\n")
    (folder / "poses.kitti").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n")
    (folder / "late.txt").write_text("1000.0 0 0 0 0 0 0 1\n1000.1 0 0 0 0 0 0 1\n")
    shutil.copy(folder / "orb.txt", folder / "x.orb.txt")
    before = (folder / "x.orb.txt").read_bytes()
    args, problem = bad_cases(folder)[case]
    code, err = record(capsys, *args, "--quiet")
    assert code == 2, err
    assert err.splitlines() == [err.strip()] and err.startswith("viewslam: error: ") and problem in err, err
    assert (folder / "x.orb.txt").read_bytes() == before and not list(folder.glob("*.rrd"))


@needs_study
@pytest.mark.slow
@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="xvfb-run is not installed (Debian package xvfb)")
def test_the_viewer_renders_the_recording_with_both_runs(kidnap, tmp_path):
    shot = tmp_path / "shot.png"
    subprocess.run(
        [
            "xvfb-run",
            "-a",
            Path(sys.executable).parent / "rerun",
            "--screenshot-to",
            shot,
            "--window-size",
            "1600x900",
            kidnap[0],
        ],
        capture_output=True,
        timeout=180,
        check=True,
    )
    image = cv2.cvtColor(cv2.imread(str(shot)), cv2.COLOR_BGR2RGB)
    assert image.shape[0] >= 900 and image.shape[1] >= 1600 and image.std() > 20
    for position, name in enumerate(RUNS):  # each run's colour is drawn
        distance = np.abs(image.astype(int) - palette.run_colour(name, position).rgb).sum(axis=2)
        assert np.count_nonzero(distance < 40) > 200, name
