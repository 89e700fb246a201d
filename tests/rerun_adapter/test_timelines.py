"""The evaluation timelines of a recording: global and segment-aligned ATE at each frame."""

import numpy as np
import rerun as rr
from fixtures_eval import perturbed, random_walk
from rerun.chunk import RrdReader
from scipy.spatial.transform import Rotation

from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.se3 import make_pose
from viewer_slam.geometry.trajectory import Trajectory
from viewer_slam.rerun_adapter.timelines import log_evaluation


def logged(path, entity: str) -> dict[int, float]:
    """Frame index -> scalar of the rows logged at ``entity``."""
    values = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == entity and not chunk.is_static:
            batch = chunk.to_record_batch().to_pydict()
            for frame, value in zip(batch["frame"], batch.get("Scalars:scalars", [])):
                if value is not None:
                    values[frame] = value[0]
    return values


def test_the_segment_aligned_ate_has_its_own_timeline_at_the_frames_with_a_pose(tmp_path):
    groundtruth = random_walk(90, seed=3)
    poses = perturbed(groundtruth, 4, sigma_m=0.002).poses.copy()
    poses[50:] = (
        make_pose(Rotation.from_rotvec(np.array([0.0, 0.3, 0.5])).as_matrix(), np.array([0.4, 0.0, -0.2])) @ poses[50:]
    )
    kept = np.r_[0:40, 50:90]  # lost for ten frames, then in another map frame
    evaluation = evaluate(groundtruth, Trajectory(groundtruth.timestamps[kept], poses[kept]))

    stream = rr.RecordingStream("viewslam-test")
    stream.save(tmp_path / "t.rrd")
    log_evaluation(stream, "est", evaluation, np.arange(90), groundtruth.timestamps)
    stream.flush()
    stream.disconnect()

    segments = logged(tmp_path / "t.rrd", "/metrics/est/ate_segments")
    ate = logged(tmp_path / "t.rrd", "/metrics/est/ate")
    assert sorted(segments) == sorted(ate) == kept.tolist()
    np.testing.assert_allclose([segments[i] for i in kept], evaluation.segment_ate.errors, rtol=1e-12)
    assert max(segments.values()) < 0.02 < max(ate.values())
