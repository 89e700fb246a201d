"""The recorder and `viewslam record` on a tiny TUM folder with scripted pipelines.

The scripted pipeline follows a known circular groundtruth in its own map frame (a fixed
rigid offset from the world), with seeded noise, a lost interval, keyframes, matches, map
points and loop closures, so every number the recording holds has an independent value.
"""

import json
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from rerun.chunk import RrdReader
from rich.console import Console
from scripted_circle import FRAMES, LOST, MAP_FROM_WORLD, NOISE_M, ScriptedPipeline

from viewer_slam.cli import main
from viewer_slam.diagnosis import signals
from viewer_slam.diagnosis.signals import measure_image
from viewer_slam.geometry.se3 import invert
from viewer_slam.geometry.trajectory import read_tum
from viewer_slam.record.command import record
from viewer_slam.record.console import print_summary
from viewer_slam.rerun_adapter.budget import SnapshotBudget
from viewer_slam.rerun_adapter.fit import CONTINUATION, LOG_LINE_CHARS
from viewer_slam.rerun_adapter.images import depth_png
from viewer_slam.rerun_adapter.timelines import coverage_so_far, frames_at, gap_starts
from viewer_slam.rerun_adapter.voxel_map import VoxelMap

RERUN = Path(sys.executable).with_name("rerun")


def chunk_rows(path: Path) -> dict[str, list[tuple[bool, int]]]:
    """Entity path -> (static, rows) of every chunk."""
    rows: dict[str, list[tuple[bool, int]]] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        rows.setdefault(chunk.entity_path, []).append((chunk.is_static, chunk.num_rows))
    return rows


def column(path: Path, entity: str, name: str) -> dict[int, list]:
    """Frame index -> values of component column ``name`` logged at ``entity`` on the frame timeline
    (the values of every row at that frame, concatenated)."""
    values: dict[int, list] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == entity and not chunk.is_static:
            batch = chunk.to_record_batch().to_pydict()
            for frame, value in zip(batch["frame"], batch.get(name, [])):
                if value is not None:
                    values.setdefault(frame, []).extend(value)
    return values


def static_column(path: Path, entity: str, name: str) -> list:
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == entity and chunk.is_static:
            batch = chunk.to_record_batch().to_pydict()
            if name in batch:
                return batch[name][-1]
    raise AssertionError(f"no static {name} at {entity}")


def test_the_recording_has_every_entity_of_the_layout(recorded):
    rows = chunk_rows(recorded.recording)
    expected = ["/world/groundtruth", "/camera/image"]
    for name in ("rgbdslam", "rtabmap"):
        expected += [
            f"/world/{name}",
            f"/world/{name}/camera",
            f"/world/{name}/trajectory",
            f"/world/{name}/odometry",
            f"/world/{name}/keyframes",
            f"/world/{name}/keyframes/latest",
            f"/world/{name}/keyframes/latest/depth",
            f"/world/{name}/loop_closures",
            f"/world/{name}/loop_closures/rejected",
            f"/world/{name}/map",
            f"/world/{name}/edges/sequential",
            f"/world/{name}/edges/local",
            f"/{name}/matches",
            f"/log/{name}",
        ]
        expected += [
            f"/metrics/{name}/{series}"
            for series in (
                "ate",
                "rpe_trans",
                "rpe_rot",
                "coverage",
                "inliers",
                "features",
                "tracking_state",
                "graph_error",
                "time/features",
                "time/ransac",
            )
        ]
    assert sorted(set(expected) - set(rows)) == []
    assert [path for path, chunks in rows.items() if any(n == 0 for _, n in chunks)] == []  # the viewer panics on them
    frames_logged = sum(n for static, n in rows["/camera/image"] if not static)
    assert frames_logged == FRAMES  # once per frame, shared by both pipelines
    assert subprocess.run([RERUN, "rrd", "verify", recorded.recording], capture_output=True).returncode == 0


def test_ate_is_logged_per_posed_frame_and_matches_the_report(recorded):
    posed = [i for i in range(FRAMES) if i not in LOST]
    for name in ("rgbdslam", "rtabmap"):
        ate = column(recorded.recording, f"/metrics/{name}/ate", "Scalars:scalars")
        assert sorted(ate) == posed
        errors = np.array([ate[i][0] for i in posed])
        block = recorded.report["pipelines"][name]["ate"]
        assert block["n"] == len(posed)
        assert np.sqrt(np.mean(errors**2)) == pytest.approx(block["rmse"], rel=1e-9)
        assert block["rmse"] < 3 * NOISE_M * np.sqrt(3)
        breaks = column(recorded.recording, f"/metrics/{name}/ate", "Clear:is_recursive")
        assert sorted(breaks) == [LOST[0]]  # the plotted line stops where tracking was lost


def test_the_map_frame_is_aligned_onto_groundtruth(recorded):
    for name in ("rgbdslam", "rtabmap"):
        translation = np.array(static_column(recorded.recording, f"/world/{name}", "Transform3D:translation"))
        rotation = np.array(static_column(recorded.recording, f"/world/{name}", "Transform3D:mat3x3"))
        world_from_map = invert(MAP_FROM_WORLD)
        assert np.allclose(translation, world_from_map[:3, 3], atol=0.02)
        assert np.allclose(rotation.reshape(3, 3, order="F"), world_from_map[:3, :3], atol=0.02)


def test_coverage_tracking_state_and_log_show_the_loss(recorded):
    name = "rtabmap"
    coverage = column(recorded.recording, f"/metrics/{name}/coverage", "Scalars:scalars")
    final = coverage[FRAMES - 1][0]
    assert final == pytest.approx(recorded.report["pipelines"][name]["coverage"]["ratio"], abs=1e-9)
    assert coverage[LOST[0] - 1][0] == 1.0 and final < 1.0
    states = column(recorded.recording, f"/metrics/{name}/tracking_state", "StateChange:state")
    assert states == {0: ["ok"], LOST[0]: ["lost"], LOST[-1] + 1: ["relocalised"], LOST[-1] + 2: ["ok"]}
    log = column(recorded.recording, f"/log/{name}", "TextLog:text")
    levels = column(recorded.recording, f"/log/{name}", "TextLog:level")
    loss = recorded.report["pipelines"][name]["tracking_lost"][0]
    assert messages_of(log[LOST[0]], levels[LOST[0]]) == [("WARN", f"{loss['text']}; the pipeline: sensor covered")]
    assert loss["text"].startswith(f"{name} lost at ") and loss["cause"] in loss["text"]
    assert log[LOST[-1] + 1] == [f"{name}: tracking recovered (relocalised on keyframe 0)"]
    assert levels[LOST[-1] + 1] == ["WARN"]


def test_the_log_has_one_line_per_verdict_for_a_frame_s_loop_closures_and_no_other_edges(recorded):
    name, loop_frame = "rgbdslam", 35  # keyframe 6: every 5th frame is one, but frame 15 (lost)
    log = column(recorded.recording, f"/log/{name}", "TextLog:text")
    levels = column(recorded.recording, f"/log/{name}", "TextLog:level")
    assert sorted(log) == [LOST[0], LOST[-1] + 1, loop_frame]  # nothing for the sequential and local edges
    messages = messages_of(log[loop_frame], levels[loop_frame])
    assert [level for level, _ in messages] == ["INFO", "DEBUG"]
    (_, accepted), (_, rejected) = messages
    assert accepted.startswith(f"{name}: 2 loop closures accepted: KF6 -> KF0 ")
    assert "KF6 -> KF1 (appearance, geometric check passed, score 0.8, 30 inliers)" in accepted
    assert rejected == f"{name}: loop closure rejected: KF6 -> KF2 (appearance, too few inliers, score 0.2, 4 inliers)"
    assert all(len(row) <= LOG_LINE_CHARS for row in log[loop_frame])


def messages_of(rows: list[str], levels: list[str]) -> list[tuple[str, str]]:
    """The log's rows joined back into messages (a continued row is indented), with their levels."""
    messages = []
    for row, level in zip(rows, levels):
        if row.startswith(CONTINUATION):
            messages[-1] = (level, f"{messages[-1][1]} {row.removeprefix(CONTINUATION)}")
        else:
            messages.append((level, row))
    return messages


def test_accepted_and_rejected_loop_closures_are_drawn_apart_in_two_colours(recorded):
    def last_row(entity: str, name: str):
        rows = column(recorded.recording, entity, name)
        return rows[max(rows)]

    accepted = last_row("/world/rgbdslam/loop_closures", "LineStrips3D:strips")
    rejected = last_row("/world/rgbdslam/loop_closures/rejected", "LineStrips3D:strips")
    assert len(accepted) == 2 and len(rejected) == 1
    assert np.allclose(accepted[0][0], rejected[0][0])  # both start at keyframe 6
    assert last_row("/world/rgbdslam/loop_closures", "LineStrips3D:colors") != last_row(
        "/world/rgbdslam/loop_closures/rejected", "LineStrips3D:colors"
    )


def test_other_edges_are_drawn_by_kind_under_their_own_entities(recorded):
    keyframes = column(recorded.recording, "/world/rgbdslam/keyframes", "Points3D:positions")
    positions = np.array(keyframes[max(keyframes)])
    for kind, step in (("sequential", 1), ("local", 2)):
        strips = column(recorded.recording, f"/world/rgbdslam/edges/{kind}", "LineStrips3D:strips")
        last = np.array(strips[max(strips)])
        assert len(last) == len(positions) - step
        assert np.allclose(last[:, 0], positions[step:]) and np.allclose(last[:, 1], positions[:-step])


def test_matches_are_cleared_while_lost(recorded):
    inliers = column(recorded.recording, "/rgbdslam/matches", "LineStrips2D:strips")
    outliers = column(recorded.recording, "/rgbdslam/matches/outliers", "LineStrips2D:strips")
    assert sorted(inliers) == sorted(outliers) == [i for i in range(FRAMES) if i not in LOST]
    assert all(len(inliers[i]) == 15 and len(outliers[i]) == 5 for i in inliers)
    clears = column(recorded.recording, "/rgbdslam/matches", "Clear:is_recursive")
    assert sorted(clears) == list(LOST)


def test_report_and_trajectories_are_written_beside_the_recording(recorded, tum_folder):
    report = json.loads(recorded.report_path.read_text())
    assert recorded.report_path == recorded.recording.with_suffix(".json")
    assert report["interrupted"] is False
    assert report["sequence"]["name"] == tum_folder.name
    for name in ("rgbdslam", "rtabmap"):
        trajectory = read_tum(recorded.recording.with_name(f"circle.{name}.txt"))
        assert len(trajectory) == FRAMES - len(LOST)
        assert report["pipelines"][name]["loop_closures"] == {"accepted": 2, "rejected": 1}
        keyframes = (FRAMES - 1) // 5 + 1 - 1  # every 5th frame but frame 15, lost
        assert report["pipelines"][name]["edges"] == {"sequential": keyframes - 1, "local": keyframes - 2, "loop": 2}


def test_ctrl_c_stops_the_run_and_keeps_what_was_recorded(scripted_pipelines, tum_folder, tmp_path):
    out = tmp_path / "stopped.rrd"
    handler = signal.getsignal(signal.SIGINT)
    result = record(str(tum_folder), out=out, quiet=True, params=["Scripted/InterruptAt=25"])
    assert result.interrupted and result.report["interrupted"] is True
    assert list(result.report["pipelines"]) == ["rgbdslam"]  # the second pipeline never started
    assert len(read_tum(result.trajectories["rgbdslam"])) == 26 - len(LOST)
    assert subprocess.run([RERUN, "rrd", "verify", out], capture_output=True).returncode == 0
    assert signal.getsignal(signal.SIGINT) is handler


def test_the_runs_of_a_record_measure_what_each_frame_shows_once(scripted_pipelines, tum_folder, tmp_path, monkeypatch):
    measured = []
    monkeypatch.setattr(signals, "measure_image", lambda frame: measured.append(frame.index) or measure_image(frame))
    result = record(str(tum_folder), out=tmp_path / "once.rrd", quiet=True)
    assert list(result.report["pipelines"]) == ["rgbdslam", "rtabmap"]
    assert measured == list(range(FRAMES))


def test_a_pipeline_that_fails_mid_run_leaves_every_frame_before_it_in_the_recording(
    scripted_pipelines, tum_folder, tmp_path, monkeypatch
):
    """The per-frame numbers and poses the recorder holds back to send as columns are sent when
    a run fails, not lost with it."""
    process = ScriptedPipeline.process

    def failing(self, frame):
        if frame.index == 25:
            raise ZeroDivisionError("a bug")
        return process(self, frame)

    monkeypatch.setattr(ScriptedPipeline, "process", failing)
    out = tmp_path / "failed.rrd"
    with pytest.raises(ZeroDivisionError, match="a bug"):
        record(str(tum_folder), out=out, quiet=True)
    assert sorted(column(out, "/metrics/rgbdslam/features", "Scalars:scalars")) == list(range(25))
    posed = sorted(column(out, "/world/rgbdslam/camera", "Transform3D:translation"))
    assert posed == [index for index in range(25) if index not in LOST]


def test_a_corrupt_frame_mid_run_exits_2_and_keeps_the_frames_before_it(
    scripted_pipelines, tum_folder, tmp_path, capsys
):
    folder = shutil.copytree(tum_folder, tmp_path / "corrupt")
    listed = [line.split()[1] for line in (folder / "rgb.txt").read_text().splitlines() if not line.startswith("#")]
    (folder / listed[25]).write_bytes(b"not a png")
    out = tmp_path / "corrupt.rrd"
    assert main(["record", str(folder), "--out", str(out), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and f"{folder / listed[25]}: not a readable image" in error and str(out) in error
    report = json.loads(out.with_suffix(".json").read_text())
    assert report["interrupted"] is True and listed[25] in report["error"]
    assert list(report["pipelines"]) == ["rgbdslam"]  # the second pipeline never started
    assert len(read_tum(out.with_name("corrupt.rgbdslam.txt"))) == 25 - len(LOST)
    assert subprocess.run([RERUN, "rrd", "verify", out], capture_output=True).returncode == 0


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--pipeline", "orbslam"], "valid pipelines are rgbdslam, rtabmap, both"),
        (["--param", "Scripted/Nope=1"], "unknown parameter 'Scripted/Nope'"),
        (["--param", "Scripted/KeyframeEvery=often"], "expects an integer"),
        (["--out", "{tmp}/x.txt"], "must have the .rrd extension"),
        (["--out", "{folder}/rgb.txt/x.rrd"], "cannot write"),
    ],
)
def test_bad_input_exits_2_with_one_line_before_any_work(
    scripted_pipelines, tum_folder, tmp_path, capsys, arguments, message
):
    arguments = [a.format(tmp=tmp_path, folder=tum_folder) for a in arguments]
    assert main(["record", str(tum_folder), *arguments, "--quiet"]) == 2
    error = capsys.readouterr().err
    assert message in error and error.count("\n") == 1
    assert not list(tmp_path.glob("*.rrd")) and not (Path("recordings") / f"{tum_folder.name}.rrd").exists()


def test_a_folder_that_is_not_a_sequence_is_bad_input(scripted_pipelines, tmp_path, capsys):
    assert main(["record", str(tmp_path), "--out", str(tmp_path / "x.rrd"), "--quiet"]) == 2
    assert "not a TUM RGB-D sequence" in capsys.readouterr().err
    assert not (tmp_path / "x.rrd").exists()


def test_the_summary_fits_an_80_column_terminal_without_cutting_a_figure():
    def block(rmse):
        return {"rmse": rmse}

    pipeline = {
        "frames_with_pose": 12000,
        "coverage": {"ratio": 0.861},
        "alignment": "rigid",
        "ate": block(10.245),
        "ate_segments": block(10.251),
        "penalized_ate": block(10.266),
        "rpe": {"trans": block(10.568), "rot": block(184.704)},
        "loop_closures": {"accepted": 2740, "rejected": 1640},
        "timing": {"fps": 115.7},
    }
    report = {
        "sequence": {"name": "360_kidnap-240-320x240-s0-v4"},
        "interrupted": False,
        "pipelines": {"rgbdslam": pipeline, "rtabmap": pipeline},
    }
    console = Console(width=80, record=True)
    print_summary(report, [], console)
    text = console.export_text()
    assert "…" not in text and max(map(len, text.splitlines())) <= 80
    assert "rigid alignment of the whole run" in text and "each tracked segment aligned on its own" in text
    assert all(
        figure in text for figure in ("12000", "86%", "10.245", "10.266", "10.568", "184.70", "2740/1640", "115.7")
    )


def test_plots_break_after_the_last_frame_with_a_value():
    present = np.array([True, True, False, False, True, False, True])
    assert gap_starts(present).tolist() == [2, 5]
    assert gap_starts(np.array([False, True, True])).tolist() == []


def test_coverage_so_far_counts_lost_time_up_to_each_frame():
    stamps = np.arange(11, dtype=float)
    coverage = coverage_so_far(stamps, [(2.0, 5.0)])
    expected = [1.0, 1.0, 1.0, 2 / 3, 2 / 4, 2 / 5, 3 / 6, 4 / 7, 5 / 8, 6 / 9, 7 / 10]
    assert np.allclose(coverage, expected)


def test_frames_at_finds_exact_stamps_only():
    frames = np.array([1.0, 1.5, 2.0])
    assert frames_at(np.array([1.5, 2.0, 1.7, 0.5, 3.0]), frames).tolist() == [1, 2, -1, -1, -1]


def test_voxel_map_keeps_one_point_per_voxel_and_caps_its_size():
    rng = np.random.default_rng(0)
    cloud = VoxelMap(voxel_size=0.1, max_points=10_000)
    points = rng.uniform(0, 1, (20_000, 3))
    cloud.update(points, np.full((20_000, 3), 200, np.uint8))
    grid_origin = points.min(axis=0) - 0.05  # Open3D's voxel grid starts half a voxel below the points
    assert len(cloud) == len(np.unique(np.floor((points - grid_origin) / 0.1), axis=0))
    assert np.all(cloud.colors == 200)
    cloud.update(points + 5.0, np.zeros((20_000, 3), np.uint8), replace=True)
    assert np.all(cloud.points > 4.9) and np.all(cloud.colors == 0)
    small = VoxelMap(voxel_size=0.01, max_points=500)
    small.update(points, np.zeros((20_000, 3), np.uint8))
    assert len(small) <= 500 and small.voxel_size > 0.01


def test_snapshot_budget_keeps_the_cost_of_a_growing_snapshot_linear():
    budget, frames, logged = SnapshotBudget(bytes_per_frame=1000), 5000, []
    for frame in range(frames):
        size = 200 * frame  # grows at every frame: re-logging it each time would cost 2.5 GB
        budget.dirty = True
        if budget.due(frame, size):
            logged.append(size)
            budget.logged(frame)
    assert sum(logged) <= 1000 * frames
    assert len(logged) > 25  # still refreshed, ever more rarely as it grows
    assert not SnapshotBudget(1000).due(0, 1)  # nothing to log while unchanged


def test_depth_png_round_trips_millimetres():
    depth = np.array([[0.0, 1.2344], [2.5, 70.0]], dtype=np.float32)
    decoded = cv2.imdecode(np.frombuffer(depth_png(depth), np.uint8), cv2.IMREAD_UNCHANGED)
    assert decoded.dtype == np.uint16 and decoded.tolist() == [[0, 1234], [2500, 65535]]
