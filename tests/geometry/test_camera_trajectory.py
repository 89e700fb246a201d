import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from viewer_slam.errors import InputError
from viewer_slam.geometry.camera import Camera
from viewer_slam.geometry.se3 import make_pose
from viewer_slam.geometry.trajectory import Trajectory, read_tum, write_tum

CAMERA = Camera(fx=535.4, fy=539.2, cx=320.1, cy=247.6, width=640, height=480)


def test_project_inverts_backproject():
    rng = np.random.default_rng(0)
    uv = rng.uniform([0, 0], [640, 480], size=(100, 2))
    z = rng.uniform(0.5, 4.0, size=100)
    np.testing.assert_allclose(CAMERA.project(CAMERA.backproject(uv, z)), uv, atol=1e-9)


def test_scaled_keeps_the_field_of_view():
    half = CAMERA.scaled(320, 240)
    assert (half.width, half.height) == (320, 240)
    # The ray through the image corner stays the same ray.
    corner_full = CAMERA.backproject(np.array([[-0.5, -0.5]]), np.ones(1))
    corner_half = half.backproject(np.array([[-0.5, -0.5]]), np.ones(1))
    np.testing.assert_allclose(corner_full, corner_half, atol=1e-12)


def test_depth_to_points_skips_invalid_pixels():
    depth = np.zeros((4, 6), np.float32)
    depth[1, 2] = 2.0
    points, pixels = CAMERA.depth_to_points(depth)
    assert pixels.tolist() == [[1, 2]]
    assert points[0, 2] == 2.0


def test_camera_json_round_trip(tmp_path):
    CAMERA.save(tmp_path / "camera.json")
    assert Camera.load(tmp_path / "camera.json") == CAMERA


def test_camera_json_missing_key_names_file(tmp_path):
    path = tmp_path / "camera.json"
    path.write_text('{"fx": 1, "fy": 1, "cx": 0}')
    with pytest.raises(
        InputError,
        match=r"camera.json: camera calibration lacks width, height, cy|camera.json: camera calibration lacks cy, width, height",
    ):
        Camera.load(path)


def test_tum_round_trip_keeps_micrometres(tmp_path):
    rng = np.random.default_rng(3)
    poses = np.stack(
        [make_pose(Rotation.from_rotvec(rng.normal(size=3)).as_matrix(), rng.normal(size=3)) for _ in range(20)]
    )
    stamps = 1305031102.160407 + np.arange(20) / 30
    write_tum(tmp_path / "t.txt", Trajectory(stamps, poses))
    back = read_tum(tmp_path / "t.txt")
    np.testing.assert_allclose(back.timestamps, stamps, atol=1e-6)
    np.testing.assert_allclose(back.positions, poses[:, :3, 3], atol=1e-6)
    np.testing.assert_allclose(back.poses[:, :3, :3], poses[:, :3, :3], atol=1e-5)


def test_tum_reader_sorts_by_time_and_skips_comments(tmp_path):
    path = tmp_path / "t.txt"
    path.write_text("# header\n2 0 0 0 0 0 0 1\n\n1 1 0 0 0 0 0 1\n")
    trajectory = read_tum(path)
    assert trajectory.timestamps.tolist() == [1.0, 2.0]
    assert trajectory.positions[0, 0] == 1.0
