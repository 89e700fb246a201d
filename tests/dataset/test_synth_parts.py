"""Parts of the generator: ray-cast rendering, the Kinect-like sensor, paths and timing."""

import numpy as np
import pytest

from viewer_slam.dataset.synth.generate import camera_model
from viewer_slam.dataset.synth.render import Renderer, dot3
from viewer_slam.dataset.synth.scenes import Scene, quad
from viewer_slam.dataset.synth.sensor import BASELINE_FOCAL, KinectModel
from viewer_slam.dataset.synth.trajectories import Path, rotation_from_angles, sensor_timing
from viewer_slam.geometry.se3 import make_pose, rotation_angle

SHAPE = (120, 160)


def measure(depth, cos=1.0, seed=0):
    ideal = np.full(SHAPE, depth, np.float32)
    return KinectModel().depth(np.random.default_rng(seed), ideal, np.full(SHAPE, cos, np.float32))


def test_depth_noise_grows_with_the_square_of_distance():
    spread = {z: np.std(measure(z)[measure(z) > 0]) for z in (1.0, 2.0)}
    assert 0.0008 < spread[1.0] < 0.003
    assert 3.0 < spread[2.0] / spread[1.0] < 5.5
    # Disparity is quantised to 1/8 pixel: at 3 m only a few depth levels occur, 2-3 cm apart.
    levels = np.unique(measure(3.0)[measure(3.0) > 0])
    assert 2 <= len(levels) <= 12
    assert np.diff(levels).min() == pytest.approx(3.0**2 / (8 * BASELINE_FOCAL), rel=0.1)


def test_no_depth_out_of_range_or_at_grazing_angles():
    assert not measure(0.4).any() and not measure(4.8).any()
    assert (measure(2.0) > 0).mean() > 0.99
    assert not measure(2.0, cos=0.05).any()


def test_depth_edges_lose_the_far_side_but_slanted_planes_stay_whole():
    rows = np.arange(SHAPE[0])[:, None] * np.ones((1, SHAPE[1]))
    slanted = (1.0 / (1 / 3.0 + rows * (1 / 0.8 - 1 / 3.0) / SHAPE[0])).astype(np.float32)
    model, rng = KinectModel(), np.random.default_rng(1)
    assert not model._edge_shadow(rng, slanted).any()
    step = np.full(SHAPE, 2.0, np.float32)
    step[:, 80:] = 1.0
    shadow = model._edge_shadow(rng, step)
    assert shadow[:, 79].all() and not shadow[:, 80:].any() and not shadow[:, :77].any()


def test_colour_noise_is_small_and_seeded():
    model = KinectModel()
    ideal = np.full(SHAPE + (3,), 128.0, np.float32)
    first = model.colour(np.random.default_rng(5), ideal)
    assert first.dtype == np.uint8 and 1.0 < np.std(first[40:80, 60:100].astype(float)) < 4.0
    assert np.array_equal(first, model.colour(np.random.default_rng(5), ideal))


def test_rotation_from_angles_points_the_optical_axis():
    R = rotation_from_angles(np.array([0.0, np.pi / 2]), np.array([0.0, np.pi / 2]), np.array([0.0, 0.0]))
    assert np.allclose(R[0], [[0, 0, 1], [-1, 0, 0], [0, -1, 0]])  # x right = -y world, y down = -z world
    assert np.allclose(R[1][:, 2], [0, 0, -1], atol=1e-12)  # looking straight down
    assert np.allclose(np.linalg.det(R), 1.0)


def test_path_interpolates_smoothly_through_keyframes():
    keyframes = [[0, 0, 0, 1, 0, 0, 0], [1, 1, 0, 1, np.pi / 2, 0, 0], [2, 1, 1, 1, np.pi, 0, 0]]
    path = Path(keyframes)
    poses = path.poses(np.linspace(0, 2, 201))
    assert np.allclose(poses[100][:3, 3], [1, 0, 1])
    steps = rotation_angle(np.einsum("nji,njk->nik", poses[:-1, :3, :3], poses[1:, :3, :3]))
    assert steps.max() < 2.5 * np.median(steps)  # no jumps
    assert np.allclose(path.poses([-1.0, 3.0]), path.poses([0.0, 2.0]))  # clamped outside


def test_sensor_timing_is_tum_like():
    timing = sensor_timing(np.random.default_rng(0), 90)
    gaps = np.diff(timing.colour)
    assert np.all(gaps > 0.02) and abs(np.mean(gaps) - 1 / 30) < 0.001 and gaps.std() > 0.0005
    offset = timing.depth - timing.colour
    assert np.abs(offset).min() > 0.001 and np.abs(offset).max() < 0.016
    assert timing.groundtruth[0] < timing.colour[0] and timing.groundtruth[-1] > timing.colour[-1]
    assert np.allclose(np.diff(timing.groundtruth), 0.01, atol=1e-6)
    assert np.array_equal(timing.colour, np.round(timing.colour, 6))


def half_black_wall(rng, h, w):
    image = np.full((h, w, 3), 255, np.uint8)
    image[:, : w // 2] = 0
    return image


def test_a_wall_facing_the_camera_renders_at_its_distance_and_the_right_way_round():
    camera = camera_model("fr3", (160, 120))
    scene = Scene(lights=((0.0, 0.0, 0.0),), ambient=1.0)
    # A wall 3 m ahead (+x), seen from the origin; its texture's left half is black.
    scene.add([quad(np.random.default_rng(0), (3.0, 4.0, 3.0), (0, -8.0, 0), (0, 0, -6.0), half_black_wall, 0.01)])
    renderer = Renderer(scene, camera)
    pose = make_pose(rotation_from_angles(np.array([0.0]), np.array([0.0]), np.array([0.0]))[0], np.zeros(3))
    depth, cos = renderer.depth(pose, 0.0)
    assert np.allclose(depth, 3.0, atol=1e-5)
    colour, _ = renderer.colour(pose, 0.0)
    wall_centre = int(round(camera.cx))  # the texture's middle lies on the optical axis
    assert colour[:, : wall_centre - 4].max() < 1 and colour[:, wall_centre + 4 :].min() > 254
    assert np.allclose(cos[60, 80], 1.0, atol=1e-3)


def test_depth_of_a_slanted_floor_is_exact_after_upsampling():
    camera = camera_model("fr3", (160, 120))
    scene = Scene()
    scene.add([quad(np.random.default_rng(0), (-10.0, 10.0, 0.0), (20.0, 0, 0), (0, -20.0, 0), half_black_wall, 0.05)])
    height, pitch = 0.8, np.radians(40)
    pose = make_pose(rotation_from_angles(np.array([0.3]), np.array([pitch]), np.array([0.1]))[0], [0, 0, height])
    depth, _ = Renderer(scene, camera).depth(pose, 0.0)
    rows, cols = np.indices(depth.shape)
    rays = np.stack([(cols - camera.cx) / camera.fx, (rows - camera.cy) / camera.fy, np.ones(depth.shape)], -1)
    down = rays @ pose[:3, :3].T  # world direction of each pixel's ray, with unit optical depth
    expected = np.where(down[..., 2] < 0, height / np.maximum(-down[..., 2], 1e-9), 0.0)
    assert np.all(expected > 0)
    assert np.allclose(depth, expected, rtol=1e-4)


def test_plane_dot_products_sum_like_einsum_bit_for_bit():
    # Shading sums on coordinate planes; the images stay byte-identical only if the sums are.
    rng = np.random.default_rng(7)
    a, b = (rng.normal(0, 3, (3, 60, 80)).astype(np.float32) for _ in range(2))
    expected = np.einsum("hwc,hwc->hw", np.moveaxis(a, 0, -1), np.moveaxis(b, 0, -1))
    assert np.array_equal(dot3(a, b), expected)
