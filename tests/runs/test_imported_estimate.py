"""An estimate file replayed as a run: per-frame poses and states, losses from its gaps, its report block."""

from pathlib import Path

import numpy as np
import pytest
from benchmark_fake_pipeline import groundtruth_pose, write_tum_folder

from viewer_slam.dataset.sources import open_source
from viewer_slam.errors import InputError
from viewer_slam.geometry.trajectory import Trajectory, write_tum
from viewer_slam.pipelines.events import FrameTracked, TrackingStatus
from viewer_slam.pipelines.run import drive
from viewer_slam.runs.replay import estimate_replay, parse_estimate
from viewer_slam.runs.run_report import pipeline_report
from viewer_slam.runs.scoring import evaluate_run

FRAMES = 30
OFFSET_M = 0.03


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    return open_source(write_tum_folder(tmp_path_factory.mktemp("seq") / "tiny", frames=FRAMES))


def estimate_file(path, sequence, frames) -> Trajectory:
    stamps = sequence.timestamps[frames]
    poses = np.array([groundtruth_pose(t) for t in stamps])
    poses[:, 0, 3] += OFFSET_M * (-1) ** np.arange(len(stamps))  # an error the alignment cannot remove
    trajectory = Trajectory(stamps, poses)
    write_tum(path, trajectory)
    return trajectory


def replay(sequence, path, **options):
    tracked = []
    run = drive(
        estimate_replay(sequence, path, **options),
        "mine",
        sequence,
        sinks=(lambda e: tracked.append(e) if isinstance(e, FrameTracked) else None,),
        **options,
    )
    return run, tracked


def test_gaps_become_lost_frames_and_a_dropped_pose_does_not(sequence, tmp_path):
    frames = [k for k in range(FRAMES) if k != 5 and not 10 <= k < 20]
    path = tmp_path / "est.txt"
    written = estimate_file(path, sequence, frames)
    run, tracked = replay(sequence, path)
    assert run.pipeline == "mine" and run.frames == FRAMES and run.parameters == {"file": str(path), "format": "tum"}
    assert len(run.trajectory) == len(frames) and run.frame_indices.tolist() == frames
    np.testing.assert_allclose(run.trajectory.poses, written.poses, rtol=0, atol=5e-6)  # TUM keeps 6 decimals
    states = [event.status for event in tracked]
    assert states == [TrackingStatus.LOST if 10 <= k < 20 else TrackingStatus.OK for k in range(FRAMES)]
    assert [event.pose is None for event in tracked] == [k not in frames for k in range(FRAMES)]
    gap = sequence.timestamps[20] - sequence.timestamps[9]
    assert run.tracking_lost == [
        {"frame": 10, "timestamp": sequence.timestamps[10], "reason": f"no pose in est.txt for {gap:.2f} s"}
    ]
    evaluation, odometry = evaluate_run(sequence.groundtruth, run, sequence.timestamps)
    assert odometry is None
    assert evaluation.coverage.lost_intervals == [(sequence.timestamps[9], sequence.timestamps[20])]
    assert evaluation.ate.stats()["n"] == len(frames)
    assert OFFSET_M * 0.9 < evaluation.ate.stats()["rmse"] < OFFSET_M * 1.1
    block = pipeline_report(run, evaluation, odometry)
    assert block["frames_with_pose"] == len(frames) and block["coverage"]["ratio"] == pytest.approx(
        1 - gap / (sequence.timestamps[-1] - sequence.timestamps[0])
    )


def test_an_estimate_that_starts_late_is_lost_from_the_first_frame(sequence, tmp_path):
    path = tmp_path / "late.txt"
    estimate_file(path, sequence, list(range(8, FRAMES)))
    run, tracked = replay(sequence, path)
    assert [event.status for event in tracked[:9]] == [TrackingStatus.LOST] * 8 + [TrackingStatus.OK]
    assert [entry["frame"] for entry in run.tracking_lost] == [0]


def test_a_short_run_keeps_the_poses_of_its_frames_only(sequence, tmp_path):
    path = tmp_path / "est.txt"
    estimate_file(path, sequence, list(range(FRAMES)))
    run, tracked = replay(sequence, path, max_frames=12, stride=2)
    assert run.frames == 12 and [event.frame_index for event in tracked] == list(range(0, 24, 2))
    assert run.trajectory.timestamps[-1] == sequence.timestamps[22] and run.tracking_lost == []


def test_kitti_poses_take_the_sequence_stamps(sequence, tmp_path):
    poses = np.array([groundtruth_pose(t) for t in sequence.timestamps])
    path = tmp_path / "poses.txt"
    path.write_text("".join(" ".join(f"{v:.17g}" for v in pose[:3].reshape(-1)) + "\n" for pose in poses))
    run, _ = replay(sequence, path)
    assert run.parameters["format"] == "kitti"
    np.testing.assert_array_equal(run.trajectory.timestamps, sequence.timestamps)


def test_estimate_option_is_name_equals_file():
    assert parse_estimate(" orb = out/CameraTrajectory.txt") == ("orb", Path("out/CameraTrajectory.txt"))
    with pytest.raises(InputError, match=r"^--estimate 'orb': expected NAME=FILE"):
        parse_estimate("orb")


RTABMAP_DATA = Path(__file__).resolve().parents[1] / "data" / "rtabmap"


def test_an_rtabmap_database_replays_its_maps_links_and_statistics():
    """The real RTAB-Map's run of 360_kidnap under its dataset tool's rule: four maps, joined."""
    from viewer_slam.dataset.frame import Frame
    from viewer_slam.geometry.camera import Camera
    from viewer_slam.geometry.rtabmap_database import read_rtabmap_database
    from viewer_slam.pipelines.events import GraphEdge, KeyframeAdded, TrackingLost, TrackingRecovered
    from viewer_slam.runs.replay import EstimateParams, EstimateReplay

    path = RTABMAP_DATA / "360_kidnap-toolrule.db"
    stamps = np.array(
        [
            float(line.split()[0])
            for line in (RTABMAP_DATA / "360_kidnap.rgb.txt").read_text().splitlines()
            if not line.startswith("#")
        ]
    )
    database = read_rtabmap_database(path)
    replay = EstimateReplay(
        EstimateParams(file=str(path)), Camera(535.4, 539.2, 320.1, 247.6, 640, 480), stamps, stamps
    )
    blank = np.zeros((1, 1, 3), np.uint8), np.zeros((1, 1), np.float32)
    events = [event for index, stamp in enumerate(stamps) for event in replay.process(Frame(index, stamp, *blank))]
    assert replay.params.format == "rtabmap"
    keyframes = [event for event in events if isinstance(event, KeyframeAdded)]
    assert [event.keyframe_id for event in keyframes] == [node.id for node in database.nodes]
    edges = [event for event in events if isinstance(event, GraphEdge)]
    for kind, detection in (("global_loop", "appearance"), ("local_space", "proximity"), ("neighbor", "odometry")):
        expected = sorted((link.from_id, link.to_id) for link in database.links if link.kind == kind)
        assert (
            sorted(
                (edge.from_keyframe, edge.to_keyframe)
                for edge in edges
                if edge.accepted and edge.detection == detection
            )
            == expected
        )
    starts = [node for previous, node in zip(database.nodes, database.nodes[1:]) if node.map_id != previous.map_id]
    recovered = [event for event in events if isinstance(event, TrackingRecovered)]
    assert [(event.timestamp, event.reason) for event in recovered] == [
        (node.stamp, f"new map {node.map_id} in {path.name}") for node in starts
    ]
    lost = [event for event in events if isinstance(event, TrackingLost)]
    assert len(lost) == len(starts) and all(a.timestamp < b.timestamp for a, b in zip(lost, recovered))
    tracked = {event.keyframe_id: event for event in events if isinstance(event, FrameTracked) and event.keyframe_id}
    assert [tracked[node.id].inliers for node in database.nodes] == [
        int(node.statistics["Odometry/Inliers/"]) for node in database.nodes
    ]
    assert [tracked[node.id].metrics["map"] for node in database.nodes] == [node.map_id for node in database.nodes]
