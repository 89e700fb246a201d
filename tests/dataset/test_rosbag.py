"""ROS bags as sequences: real bags written from the shared TUM excerpt give the folder's frames."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
from bag_writer import BagWriter, write_poses, write_tum_bag
from fixtures_eval import TUM_RPY, tum_excerpt
from scipy.spatial.transform import Rotation

from viewer_slam.cli import main
from viewer_slam.dataset.cameras import FREIBURG_CAMERAS
from viewer_slam.dataset.catalog import resolve_sequence
from viewer_slam.dataset.rosbag import BagSequence, open_bag
from viewer_slam.dataset.sources import open_source
from viewer_slam.errors import InputError
from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.se3 import make_pose
from viewer_slam.geometry.trajectory import Trajectory, read_tum, write_tum

FRAMES = 6
NAME = "rgbd_dataset_freiburg1_rpy"
needs_excerpt = pytest.mark.skipif(not TUM_RPY.is_dir(), reason="shared TUM excerpt not present")


@pytest.fixture(autouse=True)
def private_cache(monkeypatch, tmp_path):
    monkeypatch.setenv("VIEWSLAM_CACHE", str(tmp_path / "cache"))


@pytest.fixture(scope="module")
def excerpt(tmp_path_factory) -> Path:
    return tum_excerpt(tmp_path_factory.mktemp("excerpt") / NAME, frames=FRAMES)


def bag_path(folder: Path, ros: int) -> Path:
    return folder / (f"{NAME}.bag" if ros == 1 else NAME)


@pytest.fixture(scope="module", params=[1, 2], ids=["ros1", "ros2"])
def bag(request, excerpt, tmp_path_factory) -> Path:
    return write_tum_bag(
        excerpt, bag_path(tmp_path_factory.mktemp(f"ros{request.param}"), request.param), request.param
    )


@needs_excerpt
def test_a_tum_bag_opens_with_no_options_and_gives_the_folder_frames(bag, excerpt):
    folder, sequence = open_source(excerpt), open_source(bag)
    assert isinstance(sequence, BagSequence) and sequence.name == NAME
    assert sequence.topics == ("/camera/rgb/image_color", "/camera/depth/image")
    assert len(sequence) == len(folder) == FRAMES
    np.testing.assert_array_equal(sequence.timestamps, folder.timestamps)
    np.testing.assert_array_equal(sequence.depth_timestamps, folder.depth_timestamps)
    assert sequence.camera == folder.camera == FREIBURG_CAMERAS["freiburg1"]
    for ours, theirs in zip(sequence.frames(), folder.frames(), strict=True):
        assert (ours.index, ours.timestamp) == (theirs.index, theirs.timestamp)
        np.testing.assert_array_equal(ours.rgb, theirs.rgb)
        np.testing.assert_array_equal(ours.depth, theirs.depth)
        assert ours.depth.dtype == np.float32 and (ours.depth == 0).any()  # NaN became "no measurement"
    assert [frame.index for frame in sequence.frames(max_frames=2, stride=2)] == [0, 2]
    np.testing.assert_array_equal(sequence.frame(3).rgb, folder.frame(3).rgb)


@needs_excerpt
def test_the_tf_chain_from_world_to_the_colour_frame_is_the_groundtruth(bag, excerpt):
    folder, sequence = open_source(excerpt), open_source(bag)
    ours, covered = sequence.groundtruth_at(sequence.timestamps)
    theirs, folder_covered = folder.groundtruth_at(folder.timestamps)
    assert covered.all() and folder_covered.all()
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-9)
    first, last = sequence.groundtruth.timestamps[[0, -1]]
    assert first < sequence.timestamps[0] and last > sequence.timestamps[-1]


@needs_excerpt
def test_a_groundtruth_file_replaces_the_tf_chain(bag, excerpt):
    sequence = open_bag(bag, groundtruth=excerpt / "groundtruth.txt")
    assert len(sequence.groundtruth) == len(open_source(excerpt).groundtruth)


@needs_excerpt
@pytest.mark.slow
def test_recording_the_bag_writes_the_folder_trajectory_byte_for_byte(excerpt, tmp_path):
    bag = write_tum_bag(excerpt, tmp_path / f"{NAME}.bag", ros=1)
    outputs = {}
    for label, source in (("folder", excerpt), ("bag", bag)):
        out = tmp_path / label / "run.rrd"
        assert (
            main(["record", str(source), "--pipeline", "rgbdslam", "--max-frames", "5", "--out", str(out), "--quiet"])
            == 0
        )
        outputs[label] = out.with_name("run.rgbdslam.txt").read_bytes()
    assert outputs["bag"] == outputs["folder"] and outputs["bag"].count(b"\n") == 5


def synthetic_bag(
    path: Path, ros: int, topics: dict[str, str], frames: int = 3, more=lambda bag: None, tf: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """A 32x24 bag with a bgr8 topic and a 16UC1 millimetre topic (where ``topics`` names them),
    a /tf topic that never moves (unless ``tf`` is false), and what ``more(bag)`` writes."""
    rng = np.random.default_rng(0)
    bgr = rng.integers(0, 256, (frames, 24, 32, 3), dtype=np.uint8)
    millimetres = rng.integers(0, 6000, (frames, 24, 32), dtype=np.uint16)
    with BagWriter(path, ros) as bag:
        for k in range(frames):
            stamp = 5 * 10**9 + k * 33_333_333
            if "colour" in topics:
                bag.image(topics["colour"], stamp, "cam", bgr[k], "bgr8")
                bag.camera_info(
                    "/cam/camera_info", stamp, "cam", 32, 24, (40.0, 41.0, 15.5, 11.5), (0.1, -0.2, 0.0, 0.0, 0.05)
                )
            if "depth" in topics:
                bag.image(topics["depth"], stamp + 1000, "cam", millimetres[k], "16UC1")
            if tf:
                bag.transform(stamp, "/map", "/base", np.eye(4))  # tf that never moves: no groundtruth
        more(bag)
    return bgr, millimetres


def test_bgr_colour_and_millimetre_depth_with_the_camera_info_beside_them(tmp_path):
    path = tmp_path / "desk"
    bgr, millimetres = synthetic_bag(path, 2, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"})
    sequence = open_source(path)
    assert (sequence.camera.fx, sequence.camera.fy, sequence.camera.cx, sequence.camera.cy) == (40.0, 41.0, 15.5, 11.5)
    assert sequence.camera.distortion == (0.1, -0.2, 0.0, 0.0, 0.05) and sequence.groundtruth is None
    np.testing.assert_array_equal(sequence.timestamps, 5 + np.arange(3) * 0.033333333)
    for k, frame in enumerate(sequence.frames()):
        np.testing.assert_array_equal(frame.rgb, bgr[k][:, :, ::-1])
        np.testing.assert_array_equal(frame.depth, (millimetres[k] / 1000.0).astype(np.float32))


@pytest.mark.parametrize("ros", [1, 2])
def test_a_plain_bag_with_no_tf_topic_records_without_groundtruth(tmp_path, capsys, ros):
    path = tmp_path / ("plain.bag" if ros == 1 else "plain")
    synthetic_bag(path, ros, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"}, tf=False)
    assert open_source(path).groundtruth is None
    out = tmp_path / "run.rrd"
    assert main(["record", str(path), "--pipeline", "rgbdslam", "--out", str(out), "--quiet"]) == 0
    assert json.loads(out.with_suffix(".json").read_text())["pipelines"]["rgbdslam"]["ate"] is None
    estimate = tmp_path / "estimate.txt"
    estimate.write_text("5.0 0 0 0 0 0 0 1\n")
    assert main(["evaluate", str(path), str(estimate)]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"viewslam: error: {path}: no pose topic and no moving tf chain") and error.count("\n") == 1


def test_a_camera_info_that_is_no_lens_is_one_line(tmp_path):
    path = tmp_path / "nan-camera"

    def nan_intrinsics(bag):
        bag.camera_info("/cam/camera_info", 4 * 10**9, "cam", 32, 24, (float("nan"), 41.0, 15.5, 11.5))

    synthetic_bag(path, 2, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"}, more=nan_intrinsics)
    with pytest.raises(
        InputError,
        match=rf"^{path}: /cam/camera_info: bad camera calibration: fx must be a finite "
        r"number, got nan$",
    ):
        open_bag(path)


@pytest.mark.parametrize(
    "pose, problem",
    [
        (make_pose(np.eye(3), np.array([1e300, 0.0, 0.0])), "a position coordinate beyond 1e+08 m"),
        (None, "zero quaternion"),
    ],
)
def test_a_pose_topic_with_no_pose_is_one_line_naming_the_message(tmp_path, pose, problem):
    path = tmp_path / "poses"

    def poses(bag):
        write_poses(bag, "/mocap/pose", [np.eye(4), np.eye(4)])
        stamp = 9 * 10**9
        types = bag.types
        point = types["geometry_msgs/msg/Point"](x=1e300 if pose is not None else 0.0, y=0.0, z=0.0)
        quaternion = types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0 if pose is not None else 0.0)
        bag.add(
            "/mocap/pose",
            "geometry_msgs/msg/PoseStamped",
            stamp,
            types["geometry_msgs/msg/PoseStamped"](
                header=bag.header(stamp, "map"),
                pose=types["geometry_msgs/msg/Pose"](position=point, orientation=quaternion),
            ),
        )

    synthetic_bag(path, 2, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"}, more=poses)
    with pytest.raises(InputError, match=rf"^{path}: /mocap/pose at 9.000000 s: {re.escape(problem)}$"):
        open_bag(path, groundtruth_topic="/mocap/pose")


@pytest.mark.parametrize("ros", [1, 2])
def test_groundtruth_from_a_pose_topic(tmp_path, ros):
    expected = [
        make_pose(Rotation.from_rotvec(np.array([0.1 * k, 0.0, 0.2])).as_matrix(), np.array([k, 2.0 * k, 0.5]))
        for k in range(4)
    ]

    def poses(bag):
        write_poses(bag, "/mocap/pose", expected)

    path = tmp_path / ("desk.bag" if ros == 1 else "desk")
    synthetic_bag(path, ros, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"}, more=poses)
    sequence = open_bag(path, groundtruth_topic="/mocap/pose")
    np.testing.assert_array_equal(sequence.groundtruth.timestamps, 5 + np.arange(4) / 10)
    np.testing.assert_allclose(sequence.groundtruth.poses, expected, rtol=0, atol=1e-12)
    with pytest.raises(InputError, match="--groundtruth-topic /cam/image_raw: sensor_msgs/msg/Image, not one of"):
        open_bag(path, groundtruth_topic="/cam/image_raw")


def test_a_ros1_bag_path_resolves_as_a_sequence(tmp_path):
    path = tmp_path / "desk.bag"
    synthetic_bag(path, 1, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"})
    assert resolve_sequence(str(path)) == path and len(open_source(path)) == 3


@pytest.mark.parametrize(
    "topics, options, problem",
    [
        pytest.param(
            {},
            {},
            "no colour image topic (sensor_msgs/msg/Image in rgb8, bgr8, rgba8, bgra8, mono8); "
            "topics: /tf (tf2_msgs/msg/TFMessage)",
            id="no-image",
        ),
        pytest.param({"colour": "/cam/image_raw"}, {}, "no depth image topic", id="no-depth"),
        pytest.param(
            {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"},
            {"rgb_topic": "/tf"},
            "--rgb-topic /tf: is tf2_msgs/msg/TFMessage, not an image (sensor_msgs/msg/Image)",
            id="not-image",
        ),
        pytest.param(
            {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"},
            {"rgb_topic": "/cam/depth_mm"},
            "--rgb-topic /cam/depth_mm: encoding '16UC1' is not a colour encoding",
            id="depth-as-colour",
        ),
        pytest.param(
            {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"},
            {"depth_topic": "/nothing"},
            "--depth-topic /nothing: no such topic",
            id="missing-topic",
        ),
        pytest.param(
            {"colour": "/a/image", "depth": "/cam/depth_mm", "second": "/b/image"},
            {},
            "several colour image topics (/a/image, /b/image); choose one with --rgb-topic",
            id="ambiguous",
        ),
    ],
)
def test_bags_without_usable_images_name_the_bag_and_the_problem(tmp_path, topics, options, problem):
    path = tmp_path / "bad"

    def second_camera(bag):
        if "second" in topics:
            bag.image(topics["second"], 5 * 10**9, "other", np.zeros((24, 32, 3), np.uint8), "rgb8")

    synthetic_bag(path, 2, topics, more=second_camera)
    with pytest.raises(InputError) as raised:
        open_bag(path, **options)
    assert str(raised.value).startswith(f"{path}: {problem}") and "\n" not in str(raised.value)


def test_an_image_whose_data_do_not_fill_it_is_one_line(tmp_path):
    path = tmp_path / "short"

    def truncated(bag):
        message = bag.types["sensor_msgs/msg/Image"](
            header=bag.header(6 * 10**9, "cam"),
            height=24,
            width=32,
            encoding="bgr8",
            is_bigendian=0,
            step=96,
            data=np.zeros(100, np.uint8),
        )
        bag.add("/cam/image_raw", "sensor_msgs/msg/Image", 6 * 10**9, message)
        bag.image("/cam/depth_mm", 6 * 10**9, "cam", np.zeros((24, 32), np.uint16), "16UC1")

    synthetic_bag(path, 2, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"}, more=truncated)
    sequence = open_source(path)
    assert len(sequence) == 4 and sequence.frame(2).rgb.shape == (24, 32, 3)
    with pytest.raises(InputError, match=rf"^{path}: frame 3 \(6.000000 s\): malformed image \(ValueError: "):
        sequence.frame(3)


def test_record_of_a_bag_without_images_is_one_line_and_exit_2(tmp_path, capsys):
    path = tmp_path / "empty.bag"
    synthetic_bag(path, 1, {})
    out = tmp_path / "out.rrd"
    assert main(["record", str(path), "--pipeline", "rgbdslam", "--out", str(out), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"viewslam: error: {path}: no colour image topic") and error.count("\n") == 1
    assert not out.exists()


def test_a_folder_that_is_not_a_bag_is_one_line(tmp_path):
    path = tmp_path / "broken"
    path.mkdir()
    (path / "metadata.yaml").write_text("not: [a, rosbag2")
    with pytest.raises(InputError, match=rf"^{path}: not a readable ROS bag: "):
        open_source(path)


def evaluated(capsys, groundtruth: Path, estimate: Path, out: Path, *options: str) -> dict:
    assert main(["evaluate", str(groundtruth), str(estimate), "--json", str(out), *options]) == 0, (
        capsys.readouterr().err
    )
    capsys.readouterr()
    return json.loads(out.read_text())


def assert_same_scores(ours: dict, theirs: dict) -> None:
    """Every number of two evaluate reports equal to 1e-9 (the tf chain is composed, not read)."""
    assert ours.keys() == theirs.keys()
    for key, value in theirs.items():
        if isinstance(value, dict):
            assert_same_scores(ours[key], value)
        elif isinstance(value, float):
            assert ours[key] == pytest.approx(value, abs=1e-9), key
        else:
            assert ours[key] == value, key


@needs_excerpt
def test_a_tum_bag_as_evaluate_groundtruth_scores_as_its_folder(bag, excerpt, tmp_path, capsys):
    folder = open_source(excerpt)
    poses, _ = folder.groundtruth_at(folder.timestamps)
    poses[:, :3, 3] += np.random.default_rng(5).normal(0.0, 0.02, (len(poses), 3))
    estimate = tmp_path / "estimate.txt"
    write_tum(estimate, Trajectory(folder.timestamps, poses))
    from_bag = evaluated(capsys, bag, estimate, tmp_path / "bag.json")
    from_folder = evaluated(capsys, excerpt, estimate, tmp_path / "folder.json")
    assert_same_scores(from_bag, from_folder)
    assert from_bag["ate"]["n"] == FRAMES and from_bag["coverage"]["span"]["rule"] == "sequence frames"


@pytest.mark.parametrize("ros", [1, 2])
def test_a_bag_of_poses_alone_is_groundtruth_as_the_same_poses_in_a_file(tmp_path, capsys, ros):
    truth = [
        make_pose(Rotation.from_rotvec(np.array([0.0, 0.05 * k, 0.0])).as_matrix(), np.array([0.1 * k, 0.0, 0.02 * k]))
        for k in range(30)
    ]
    path = tmp_path / ("mocap.bag" if ros == 1 else "mocap")
    with BagWriter(path, ros) as bag:
        write_poses(bag, "/vrpn/camera/pose", truth, step_ns=50_000_000)
    stamps = 5 + np.arange(30) * 0.05
    noisy = np.array(truth)
    noisy[:, :3, 3] += np.random.default_rng(6).normal(0.0, 0.01, (30, 3))
    write_tum(tmp_path / "estimate.txt", Trajectory(stamps, noisy))
    from_bag = evaluated(capsys, path, tmp_path / "estimate.txt", tmp_path / "bag.json")
    expected = evaluate(Trajectory(stamps, np.array(truth)), read_tum(tmp_path / "estimate.txt")).to_dict()
    assert_same_scores(from_bag, json.loads(json.dumps(expected)))
    assert from_bag["ate"]["n"] == 30 and from_bag["ate"]["rmse"] > 0.005
    named = evaluated(
        capsys, path, tmp_path / "estimate.txt", tmp_path / "named.json", "--groundtruth-topic", "/vrpn/camera/pose"
    )
    assert named == from_bag


def test_a_bag_without_a_pose_topic_is_one_line_as_evaluate_groundtruth(tmp_path, capsys):
    still = tmp_path / "still.bag"
    synthetic_bag(still, 1, {"colour": "/cam/image_raw", "depth": "/cam/depth_mm"})  # its tf never moves
    estimate = tmp_path / "estimate.txt"
    estimate.write_text("5.0 0 0 0 0 0 0 1\n5.1 0.1 0 0 0 0 0 1\n")
    for arguments, problem, named in (
        ([still], "no pose topic and no moving tf chain to the colour camera", still),
        ([still, "--groundtruth-topic", "/cam/image_raw"], "not one of", still),
        ([estimate, "--groundtruth-topic", "/pose"], "only for a ROS bag", estimate),
    ):
        assert main(["evaluate", str(arguments[0]), str(estimate), *map(str, arguments[1:])]) == 2
        error = capsys.readouterr().err.strip()
        assert problem in error and str(named) in error and "\n" not in error and "Traceback" not in error


@pytest.mark.parametrize("ros", [1, 2])
def test_a_bag_as_an_estimate_is_its_pose_topic(tmp_path, capsys, ros):
    stamps = 5 + np.arange(30) * 0.05
    truth = np.array(
        [
            make_pose(Rotation.from_rotvec(np.array([0.02 * k, 0.0, 0.0])).as_matrix(), np.array([0.0, 0.1 * k, 0.0]))
            for k in range(30)
        ]
    )
    write_tum(tmp_path / "truth.txt", Trajectory(stamps, truth))
    estimate = truth.copy()
    estimate[:, :3, 3] += np.random.default_rng(7).normal(0.0, 0.01, (30, 3))
    path = tmp_path / ("slam.bag" if ros == 1 else "slam")
    with BagWriter(path, ros) as bag:
        write_poses(bag, "/slam/pose", estimate, step_ns=50_000_000)
    scores = evaluated(capsys, tmp_path / "truth.txt", path, tmp_path / "bag.json")
    expected = evaluate(read_tum(tmp_path / "truth.txt"), Trajectory(stamps, estimate)).to_dict()
    assert_same_scores(scores, json.loads(json.dumps(expected)))
    assert main(["evaluate", str(tmp_path / "truth.txt"), str(path), "--estimate-topic", "/nope"]) == 2
    error = capsys.readouterr().err.strip()
    assert "--estimate-topic /nope: no such topic" in error and str(path) in error and "\n" not in error
