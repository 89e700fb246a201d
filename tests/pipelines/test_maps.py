import numpy as np

from viewer_slam.geometry.se3 import transform_points
from viewer_slam.pipelines.events import MapUpdated
from viewer_slam.pipelines.maps import rebuilt_map
from viewer_slam.rerun_adapter.voxel_map import VoxelMap


def clouds(count: int, points: int = 50) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(count)
    poses = [np.eye(4) for _ in range(count)]
    for index, pose in enumerate(poses):
        pose[:3, 3] = (index, 0.5 * index, 0.0)
    return [(pose, rng.normal(size=(points, 3)), rng.integers(0, 256, (points, 3), dtype=np.uint8)) for pose in poses]


def test_a_rebuilt_map_holds_the_poses_it_was_made_at_not_those_it_is_read_at():
    nodes = clouds(4)
    event = rebuilt_map(7, nodes, max_points=1000)
    expected = np.concatenate([transform_points(pose, points) for pose, points, _ in nodes]).astype(np.float32)
    for pose, _, _ in nodes:  # the pipeline moves on: later optimisations replace or change its poses
        pose[:3, 3] += 10.0
    assert event.point_count == 200 and event.replace and event.frame_index == 7
    assert np.array_equal(event.points, expected)
    assert np.array_equal(event.colors, np.concatenate([colors for _, _, colors in nodes]))


def test_a_rebuilt_map_is_thinned_evenly_to_its_limit_and_counts_its_points_before_building():
    event = rebuilt_map(0, clouds(3, points=101), max_points=100)  # 303 points, every 4th kept
    assert event.point_count == 76
    assert len(event.points) == len(event.colors) == 76
    assert rebuilt_map(0, [], max_points=100).point_count == 0


def test_the_recorders_map_builds_only_the_updates_it_still_holds_when_read():
    built = []

    def deferred(offset: float) -> MapUpdated:
        def build():
            built.append(offset)
            return np.full((5, 3), offset), np.zeros((5, 3), np.uint8)

        return MapUpdated.deferred(0, build, 5, replace=True)

    cloud = VoxelMap(voxel_size=0.01)
    for offset in (1.0, 2.0, 3.0):  # each replaces the one before
        cloud.add(deferred(offset))
    assert cloud.size_estimate == 5 and built == []
    assert np.allclose(cloud.points, 3.0) and built == [3.0]
