"""The TUM folder reader, on the real fr1/rpy excerpt and on small folders built here."""

import logging
from pathlib import Path

import cv2
import numpy as np
import pytest
from fixtures_eval import TUM_RPY, read_tum_file_list, tum_associate

from viewer_slam.dataset.cameras import FREIBURG_CAMERAS, ROS_DEFAULT_CAMERA
from viewer_slam.dataset.tum import open_tum
from viewer_slam.errors import InputError
from viewer_slam.geometry.camera import Camera
from viewer_slam.geometry.se3 import invert, rotation_angle


@pytest.fixture(scope="module")
def rpy():
    return open_tum(TUM_RPY)


def make_sequence(
    folder: Path, frames: int = 4, size=(32, 24), camera: Camera | None = None, groundtruth_span=None
) -> Path:
    """A tiny TUM folder: colour i has value 10*i, depth i is (i+1) metres, 30 Hz."""
    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    width, height = size
    rgb_lines, depth_lines = ["# color images"], ["# depth maps"]
    for i in range(frames):
        stamp = 10.0 + i / 30
        colour = np.zeros((height, width, 3), np.uint8)
        colour[..., 2] = 10 * i  # BGR on disk: red channel
        cv2.imwrite(str(folder / f"rgb/{stamp:.6f}.png"), colour)
        cv2.imwrite(str(folder / f"depth/{stamp + 0.004:.6f}.png"), np.full((height, width), 5000 * (i + 1), np.uint16))
        rgb_lines.append(f"{stamp:.6f} rgb/{stamp:.6f}.png")
        depth_lines.append(f"{stamp + 0.004:.6f} depth/{stamp + 0.004:.6f}.png")
    (folder / "rgb.txt").write_text("\n".join(rgb_lines) + "\n")
    (folder / "depth.txt").write_text("\n".join(depth_lines) + "\n")
    if groundtruth_span is not None:
        stamps = np.arange(*groundtruth_span, 0.01)
        (folder / "groundtruth.txt").write_text("".join(f"{t:.4f} {t} 0 0 0 0 0 1\n" for t in stamps))
    if camera is not None:
        camera.save(folder / "camera.json")
    return folder


def test_colour_and_depth_are_associated_as_tums_tool_does(rpy):
    expected = tum_associate(
        list(read_tum_file_list(TUM_RPY / "rgb.txt")), list(read_tum_file_list(TUM_RPY / "depth.txt")), 0.0, 0.02
    )
    assert len(rpy) == len(expected) == 87
    assert list(zip(rpy.timestamps.tolist(), rpy.depth_timestamps.tolist())) == expected
    assert rpy.duration_s == pytest.approx(1305031232.393714 - 1305031229.528748)


def test_frames_are_rgb_uint8_and_float32_metres(rpy):
    frame = rpy.frame(5)
    on_disk_bgr = cv2.imread(str(TUM_RPY / "rgb" / f"{rpy.timestamps[5]:.6f}.png"))
    on_disk_depth = cv2.imread(str(TUM_RPY / "depth" / f"{rpy.depth_timestamps[5]:.6f}.png"), cv2.IMREAD_UNCHANGED)
    assert frame.index == 5 and frame.timestamp == rpy.timestamps[5]
    assert frame.rgb.dtype == np.uint8 and frame.rgb.shape == (480, 640, 3)
    np.testing.assert_array_equal(frame.rgb, on_disk_bgr[..., ::-1])
    assert frame.depth.dtype == np.float32 and frame.depth.shape == (480, 640)
    np.testing.assert_array_equal(frame.depth, (on_disk_depth / 5000.0).astype(np.float32))  # to the bit
    valid = frame.depth[frame.depth > 0]
    assert valid.min() > 0.5 and valid.max() < 10.0


def test_camera_is_the_published_freiburg1_calibration(rpy):
    assert rpy.camera == FREIBURG_CAMERAS["freiburg1"]
    assert (rpy.camera.fx, rpy.camera.fy, rpy.camera.cx, rpy.camera.cy) == (517.3, 516.5, 318.6, 255.3)
    assert rpy.camera.distortion == (0.2624, -0.9531, -0.0054, 0.0026, 1.1633)
    assert rpy.camera.depth_factor == 5000


def test_groundtruth_at_a_groundtruth_stamp_is_that_pose_and_between_stamps_lies_between(rpy):
    groundtruth = rpy.groundtruth
    assert len(groundtruth) == 391
    poses, covered = rpy.groundtruth_at(groundtruth.timestamps[[10, 200]])
    assert covered.all()
    np.testing.assert_array_equal(poses, groundtruth.poses[[10, 200]])

    before, after = groundtruth.poses[100], groundtruth.poses[101]
    t0, t1 = groundtruth.timestamps[100:102]
    middle_stamp = t0 + 0.7 * (t1 - t0)
    fraction = (middle_stamp - t0) / (t1 - t0)  # 0.7 up to the stamps' float resolution
    [middle], _ = rpy.groundtruth_at([middle_stamp])
    low, high = np.minimum(before[:3, 3], after[:3, 3]), np.maximum(before[:3, 3], after[:3, 3])
    assert np.all(low - 1e-12 <= middle[:3, 3]) and np.all(middle[:3, 3] <= high + 1e-12)
    np.testing.assert_allclose(middle[:3, 3], (1 - fraction) * before[:3, 3] + fraction * after[:3, 3], atol=1e-12)
    total = rotation_angle((invert(before) @ after)[:3, :3])
    assert rotation_angle((invert(before) @ middle)[:3, :3]) == pytest.approx(fraction * total, rel=1e-6)
    assert rotation_angle((invert(middle) @ after)[:3, :3]) == pytest.approx((1 - fraction) * total, rel=1e-6)


def test_every_frame_of_the_excerpt_has_groundtruth_and_stamps_beyond_it_do_not(rpy):
    assert rpy.frames_outside_groundtruth().tolist() == []
    _, covered = rpy.groundtruth_at([rpy.groundtruth.timestamps[0] - 0.01, rpy.groundtruth.timestamps[-1] + 0.01])
    assert not covered.any()


def test_frames_outside_groundtruth_are_reported(tmp_path):
    sequence = open_tum(
        make_sequence(tmp_path / "freiburg3_x", frames=6, size=(640, 480), groundtruth_span=(10.0, 10.105))
    )
    assert sequence.frames_outside_groundtruth().tolist() == [4, 5]  # stamps 10.133, 10.167


def test_accelerometer_is_read_when_present(rpy, tmp_path):
    assert rpy.accelerometer.shape == (1942, 4)
    assert rpy.accelerometer[0].tolist() == [1305031229.029918, -4.789573, 6.094731, -6.082757]
    assert open_tum(make_sequence(tmp_path / "freiburg2_x")).accelerometer is None


def test_frames_are_lazy_with_stride_and_limit(tmp_path):
    sequence = open_tum(make_sequence(tmp_path / "seq", frames=7, camera=Camera(30, 30, 16, 12, 32, 24)))
    frames = sequence.frames(max_frames=3, stride=2)
    assert not isinstance(frames, list)
    chosen = list(frames)
    assert [frame.index for frame in chosen] == [0, 2, 4]
    assert [frame.rgb[0, 0, 0] for frame in chosen] == [0, 20, 40]  # red first: converted from BGR
    assert [float(frame.depth[0, 0]) for frame in chosen] == [1.0, 3.0, 5.0]


def test_reading_ahead_keeps_the_order_raises_in_place_and_stops_with_the_consumer(tmp_path):
    folder = make_sequence(tmp_path / "seq", frames=8, camera=Camera(30, 30, 16, 12, 32, 24))
    sequence = open_tum(folder)
    read = []
    frame = sequence.frame
    sequence.frame = lambda index: read.append(index) or frame(index)
    first_two = sequence.frames()
    assert [next(first_two).index, next(first_two).index] == [0, 1]
    first_two.close()
    assert read[:2] == [0, 1] and set(read) <= {0, 1, 2, 3}  # at most READ_AHEAD_FRAMES beyond the consumer
    broken = sorted((folder / "rgb").iterdir())[5]
    broken.write_bytes(b"not a png")
    indices = []
    with pytest.raises(InputError, match=broken.name):
        for item in sequence.frames():
            indices.append(item.index)
    assert indices == [0, 1, 2, 3, 4]


def test_camera_json_wins_then_the_folder_name_then_the_ros_default(tmp_path, caplog):
    own = Camera(30.0, 31.0, 16.0, 12.0, 32, 24, depth_factor=1000.0)
    assert open_tum(make_sequence(tmp_path / "freiburg1_with_json", camera=own)).camera == own
    named = open_tum(make_sequence(tmp_path / "rgbd_dataset_freiburg2_desk"))
    assert named.camera == FREIBURG_CAMERAS["freiburg2"]
    with caplog.at_level(logging.WARNING):
        assert open_tum(make_sequence(tmp_path / "my_sequence")).camera == ROS_DEFAULT_CAMERA
    [record] = caplog.records
    assert "my_sequence" in record.getMessage() and "ROS default" in record.getMessage()


def test_depth_factor_comes_from_the_camera(tmp_path):
    camera = Camera(30.0, 30.0, 16.0, 12.0, 32, 24, depth_factor=1000.0)
    frame = open_tum(make_sequence(tmp_path / "seq", camera=camera)).frame(0)
    assert float(frame.depth[0, 0]) == 5.0


@pytest.mark.parametrize("depth_factor", [5000.0, 1000.0, 5208.0, 1.0, 5000.1, 1000 / 3])  # the last two: not float32
def test_every_16_bit_depth_reads_as_dividing_by_the_factor_gives_it(tmp_path, depth_factor):
    """Depth images are converted (in float32, or by a table for a factor float32 cannot
    hold) to the bit as dividing and rounding to float32 gives, for every value a PNG can hold."""
    every = np.arange(1 << 16, dtype=np.uint16).reshape(256, 256)
    folder = tmp_path / "seq"
    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    cv2.imwrite(str(folder / "rgb" / "0.png"), np.zeros((256, 256, 3), np.uint8))
    cv2.imwrite(str(folder / "depth" / "0.png"), every)
    (folder / "rgb.txt").write_text("0.0 rgb/0.png\n")
    (folder / "depth.txt").write_text("0.0 depth/0.png\n")
    Camera(200.0, 200.0, 128.0, 128.0, 256, 256, depth_factor=depth_factor).save(folder / "camera.json")
    depth = open_tum(folder).frame(0).depth
    expected = (every / depth_factor).astype(np.float32)
    assert depth.dtype == np.float32 and np.array_equal(depth.view(np.uint32), expected.view(np.uint32))


def test_a_folder_without_rgb_and_depth_lists_is_not_a_sequence(tmp_path):
    (tmp_path / "rgb.txt").write_text("1.0 rgb/1.png\n")
    with pytest.raises(InputError, match=r"not a TUM RGB-D sequence \(no depth.txt\)"):
        open_tum(tmp_path)
    with pytest.raises(InputError, match="no such folder"):
        open_tum(tmp_path / "absent")


@pytest.mark.parametrize(
    ("content", "problem"),
    [(b"not a png at all", "not a readable image"), (None, "truncated PNG"), (b"", "not a readable image")],
)
def test_an_unreadable_png_names_the_file(tmp_path, content, problem):
    folder = make_sequence(tmp_path / "seq", camera=Camera(30, 30, 16, 12, 32, 24))
    broken = sorted((folder / "rgb").iterdir())[1]
    intact = broken.read_bytes()
    broken.write_bytes(intact[: len(intact) // 2] if content is None else content)
    sequence = open_tum(folder)
    sequence.frame(0)
    with pytest.raises(InputError) as error:
        sequence.frame(1)
    assert str(error.value) == f"{broken}: {problem}"


def test_a_malformed_listing_line_is_reported_with_its_number(tmp_path):
    folder = make_sequence(tmp_path / "seq")
    (folder / "depth.txt").write_text("# depth maps\n10.0 depth/a.png\n10.1 depth/b.png extra\n")
    with pytest.raises(InputError) as error:
        open_tum(folder)
    assert str(error.value) == f"{folder / 'depth.txt'}:3: expected 2 fields, found 3"


def test_images_that_do_not_fit_the_camera_are_refused(tmp_path):
    sequence = open_tum(make_sequence(tmp_path / "freiburg1_small"))  # 32x24 images, 640x480 camera
    first_rgb = sorted((tmp_path / "freiburg1_small" / "rgb").iterdir())[0]
    with pytest.raises(InputError) as error:
        sequence.frame(0)
    assert str(error.value) == f"{first_rgb}: image is 32x24 but the camera is 640x480 (add a camera.json)"


def test_a_depth_image_that_is_not_16_bit_is_refused(tmp_path):
    folder = make_sequence(tmp_path / "seq", camera=Camera(30, 30, 16, 12, 32, 24))
    first_depth = sorted((folder / "depth").iterdir())[0]
    cv2.imwrite(str(first_depth), np.zeros((24, 32), np.uint8))
    with pytest.raises(InputError, match="depth image must be single-channel 16-bit, found uint8"):
        open_tum(folder).frame(0)
