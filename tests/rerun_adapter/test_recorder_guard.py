"""The recorder never sends an empty batch, and sizes its frustum from the poses when there is no groundtruth."""

import numpy as np
import pytest
import rerun as rr

from viewer_slam import palette
from viewer_slam.dataset.frame import Frame
from viewer_slam.geometry.camera import Camera
from viewer_slam.geometry.se3 import make_pose
from viewer_slam.pipelines.events import (
    FeatureMatches,
    FrameTracked,
    GraphOptimized,
    MapUpdated,
    TrackingStatus,
    TrajectoryFinal,
)
from viewer_slam.rerun_adapter.recorder import PipelineRecorder
from viewer_slam.rerun_adapter.sizes import scene_sizes

CAMERA = Camera(fx=50.0, fy=50.0, cx=31.5, cy=23.5, width=64, height=48)


class CapturingStream:
    """Stands in for a RecordingStream: keeps what is logged, and what is sent as columns."""

    def __init__(self):
        self.logged: list[tuple[str, object]] = []
        self.sent: list[tuple[str, list]] = []

    def log(self, path, archetype, static=False):
        self.logged.append((path, archetype))

    def send_columns(self, path, indexes, columns):
        self.sent.append((path, list(columns)))

    def set_time(self, *args, **kwargs):
        pass


def frame(index: int) -> Frame:
    return Frame(
        index=index, timestamp=float(index), rgb=np.zeros((48, 64, 3), np.uint8), depth=np.zeros((48, 64), np.float32)
    )


def empty_batches(archetype) -> list:
    return [batch for batch in archetype.as_component_batches() if len(batch.as_arrow_array()) == 0]


def empty_rows(columns) -> list:
    """The columns holding a row that is an empty batch (null where a row logs other components)."""
    return [column for column in columns if 0 in column.as_arrow_array().value_lengths().drop_null().to_pylist()]


def cleared_by_columns(stream: CapturingStream) -> set[str]:
    return {
        path
        for path, columns in stream.sent
        if any(column.component_descriptor().component == "Clear:is_recursive" for column in columns)
    }


def test_nothing_to_draw_is_sent_as_a_clear_never_as_an_empty_batch():
    stream = CapturingStream()
    recorder = PipelineRecorder(stream, "p", CAMERA, palette.run_colour("p"), scene_extent=1.0)
    recorder.begin_frame(frame(0))
    points = np.zeros((4, 2))
    recorder(FeatureMatches(0, "keyframe", points, points + 1, np.ones(4, bool)))  # no outliers
    recorder(MapUpdated(0, np.zeros((0, 3)), np.zeros((0, 3), np.uint8)))
    recorder(GraphOptimized(0, np.zeros(0, int), np.zeros((0, 4, 4)), 0.0, 0.0))
    recorder(FrameTracked(0, 0.0, None, TrackingStatus.LOST))
    recorder(TrajectoryFinal(np.zeros(0, int), np.zeros(0), np.zeros((0, 4, 4)), np.zeros((0, 4, 4))))
    assert [(path, type(a).__name__, empty_batches(a)) for path, a in stream.logged if empty_batches(a)] == []
    assert [(path, empty_rows(columns)) for path, columns in stream.sent if empty_rows(columns)] == []
    cleared = {path for path, archetype in stream.logged if isinstance(archetype, rr.Clear)} | cleared_by_columns(
        stream
    )
    assert {"p/matches/outliers", "world/p/map", "world/p/keyframes", "world/p/trajectory"} <= cleared


def frustum_depths(stream: CapturingStream) -> list[float]:
    return [
        float(archetype.image_plane_distance.as_arrow_array()[0].as_py())
        for path, archetype in stream.logged
        if path == "world/p/camera" and isinstance(archetype, rr.Pinhole)
    ]


def test_without_groundtruth_the_frustum_grows_with_the_poses_seen():
    stream = CapturingStream()
    recorder = PipelineRecorder(stream, "p", CAMERA, palette.run_colour("p"))
    for index, x in enumerate(np.linspace(0.0, 2.0, 21)):
        recorder.begin_frame(frame(index))
        recorder(FrameTracked(index, float(index), make_pose(np.eye(3), np.array([x, 0.0, 0.0])), TrackingStatus.OK))
    depths = frustum_depths(stream)
    assert depths[0] == pytest.approx(scene_sizes(0.0).frustum_depth)
    assert depths[-1] == pytest.approx(scene_sizes(2.0).frustum_depth, rel=0.25)
    assert all(later >= 1.25 * earlier * 0.999 for earlier, later in zip(depths, depths[1:]))
    assert len(depths) < 21  # re-logged when the scene has grown by a quarter, not at every frame


def test_with_groundtruth_the_frustum_keeps_the_scene_s_size():
    stream = CapturingStream()
    recorder = PipelineRecorder(stream, "p", CAMERA, palette.run_colour("p"), scene_extent=0.27)
    for index, x in enumerate(np.linspace(0.0, 2.0, 5)):
        recorder.begin_frame(frame(index))
        recorder(FrameTracked(index, float(index), make_pose(np.eye(3), np.array([x, 0.0, 0.0])), TrackingStatus.OK))
    assert frustum_depths(stream) == [pytest.approx(scene_sizes(0.27).frustum_depth)]
