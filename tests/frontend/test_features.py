import cv2
import numpy as np
import pytest

from viewer_slam.dataset.frame import Frame
from viewer_slam.errors import InputError
from viewer_slam.frontend.adjuster import AdjustedDetector, GridDetector, cell_ranges
from viewer_slam.frontend.features import DETECTORS, FeatureExtractor, match_descriptors
from viewer_slam.geometry.camera import Camera

CAMERA = Camera(fx=267.7, fy=269.6, cx=159.8, cy=119.6, width=320, height=240)


def textured_image(seed=0):
    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur((rng.random((240, 320)) * 255).astype(np.uint8), (5, 5), 1.5)
    return np.dstack([noise] * 3)


@pytest.mark.parametrize("kind", DETECTORS)
def test_detectors_find_the_known_shift(kind):
    rgb = textured_image()
    depth = np.full((240, 320), 1.5, np.float32)
    extractor = FeatureExtractor(kind, 300, CAMERA, grid=3)
    first = extractor.extract(rgb, depth)
    second = extractor.extract(np.roll(rgb, 4, axis=1), depth)
    assert 50 <= len(first) <= 300
    query, train = match_descriptors(first.descriptors, second.descriptors, first.binary, 0.8)
    assert len(query) > 0.5 * len(first)
    shift = second.keypoints[train] - first.keypoints[query]
    np.testing.assert_allclose(np.median(shift, axis=0), [4, 0], atol=0.5)
    assert len(np.unique(train)) == len(train)


def test_the_frame_s_grey_is_converted_once_and_extracts_the_features_its_colour_does():
    rng = np.random.default_rng(5)
    rgb = cv2.GaussianBlur((rng.random((240, 320, 3)) * 255).astype(np.uint8), (5, 5), 1.5)  # colour, not grey
    depth = np.full((240, 320), 1.5, np.float32)
    frame = Frame(0, 0.0, rgb, depth)
    assert frame.grey is frame.grey
    assert np.array_equal(frame.grey, cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))
    from_colour = FeatureExtractor("ORB", 300, CAMERA, grid=3, adjuster_iterations=3).extract(rgb, depth)
    from_grey = FeatureExtractor("ORB", 300, CAMERA, grid=3, adjuster_iterations=3).extract(rgb, depth, frame.grey)
    assert len(from_colour) > 50
    for field in ("keypoints", "descriptors", "responses", "points"):
        assert getattr(from_grey, field).tobytes() == getattr(from_colour, field).tobytes()


def test_points_are_nan_without_depth_and_backprojected_with_it():
    rgb = textured_image(1)
    depth = np.full((240, 320), 2.0, np.float32)
    depth[:, :160] = 0.0
    features = FeatureExtractor("ORB", 300, CAMERA).extract(rgb, depth)
    left = features.keypoints[:, 0] < 159
    right = features.keypoints[:, 0] > 160
    assert not features.has_depth[left].any()
    assert features.has_depth[right].all()
    np.testing.assert_allclose(features.points[right, 2], 2.0)
    np.testing.assert_allclose(CAMERA.project(features.points[right]), features.keypoints[right], atol=1e-4)


def test_grid_cells_overlap_by_the_orb_border():
    assert cell_ranges(240, 3) == [(0, 111), (49, 191), (129, 240)]  # 80-pixel cells widened by 31


def test_a_cell_with_too_few_keypoints_lowers_its_threshold_by_0_7_per_try():
    blank = np.zeros((100, 100), np.uint8)
    detector = AdjustedDetector("ORB", 67, 100, iterations=5)
    assert len(detector.detect(blank)) == 0
    assert detector.threshold == pytest.approx(20 * 0.7**5)  # five tries from v2's start of 20
    detector.detect(blank)
    detector.detect(blank)  # 20 * 0.7^7 < 2: held at the floor of 2, where adjusting stops
    assert detector.threshold == 2


def test_a_cell_with_too_many_keypoints_raises_its_threshold_by_1_3_for_the_next_frame():
    noise = np.random.default_rng(0).integers(0, 255, (200, 200), dtype=np.uint8)
    detector = AdjustedDetector("ORB", 5, 10, iterations=5)
    assert len(detector.detect(noise)) > 10
    assert detector.threshold == pytest.approx(26.0)


def test_grid_shares_the_keypoint_budget_between_cells():
    grid = GridDetector("ORB", 600, 3, iterations=5)
    assert grid.per_cell == 100  # 1.5 * 600 / 9
    assert {(d.low, d.high) for d in grid.detectors} == {(67, 100)}


def test_blank_image_gives_no_features():
    features = FeatureExtractor("GFTT_ORB", 500, CAMERA).extract(
        np.zeros((240, 320, 3), np.uint8), np.zeros((240, 320), np.float32)
    )
    assert len(features) == 0
    assert match_descriptors(features.descriptors, features.descriptors, True, 0.8)[0].size == 0


def test_surf_is_refused_with_the_reason():
    with pytest.raises(InputError, match="SURF is patented"):
        FeatureExtractor("SURF", 500, CAMERA)


def test_distorted_keypoints_are_backprojected_along_the_undistorted_ray():
    distorted = Camera(
        fx=517.3,
        fy=516.5,
        cx=318.6,
        cy=255.3,
        width=640,
        height=480,
        distortion=(0.2624, -0.9531, -0.0054, 0.0026, 1.1633),
    )
    rng = np.random.default_rng(2)
    points = np.column_stack([rng.uniform(-1, 1, 50), rng.uniform(-0.7, 0.7, 50), rng.uniform(1, 3, 50)])
    pixels, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), distorted.K, np.array(distorted.distortion))
    pixels = pixels.reshape(-1, 2)
    inside = (pixels[:, 0] > 1) & (pixels[:, 0] < 638) & (pixels[:, 1] > 1) & (pixels[:, 1] < 478)
    depth = np.zeros((480, 640), np.float32)
    extractor = FeatureExtractor("ORB", 10, distorted)
    for (u, v), z in zip(pixels[inside], points[inside, 2]):
        depth[int(np.rint(v)), int(np.rint(u))] = z
    back = extractor.backproject(pixels[inside].astype(np.float32), depth)
    np.testing.assert_allclose(back, points[inside], atol=2e-3 * points[inside, 2:].max())
