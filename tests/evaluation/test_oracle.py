"""On pre-associated pairs, our ATE and RPE equal evo's to 1e-9 relative."""

import numpy as np
import pytest
from evo.core import metrics
from evo.core.trajectory import PoseTrajectory3D
from fixtures_eval import TRAJECTORIES, perturbed, random_walk
from scipy.spatial.transform import Rotation

from viewer_slam.evaluation import evaluate
from viewer_slam.geometry.association import associate
from viewer_slam.geometry.se3 import make_pose
from viewer_slam.geometry.trajectory import Trajectory, read_tum


def pre_associated(groundtruth_name: str, estimate_name: str) -> tuple[Trajectory, Trajectory]:
    """The associated poses of both files, stamped identically so any association keeps them all."""
    groundtruth = read_tum(TRAJECTORIES / groundtruth_name)
    estimate = read_tum(TRAJECTORIES / estimate_name)
    i, j = associate(groundtruth.timestamps, estimate.timestamps)
    stamps = estimate.timestamps[j]
    return Trajectory(stamps, groundtruth.poses[i]), Trajectory(stamps, estimate.poses[j])


def random_pair(seed: int) -> tuple[Trajectory, Trajectory]:
    groundtruth = random_walk(300, seed)
    estimate = perturbed(groundtruth, seed + 1)
    rng = np.random.default_rng(seed)
    moved = make_pose(
        Rotation.from_rotvec(rng.normal(size=3)).as_matrix(), rng.normal(scale=3.0, size=3)
    )  # the estimate's own frame
    return groundtruth, Trajectory(estimate.timestamps, moved @ estimate.poses)


def evo_errors(groundtruth: Trajectory, estimate: Trajectory) -> dict[str, np.ndarray]:
    reference = PoseTrajectory3D(poses_se3=list(groundtruth.poses), timestamps=groundtruth.timestamps)
    estimated = PoseTrajectory3D(poses_se3=list(estimate.poses), timestamps=estimate.timestamps)
    errors = {}
    for name, relation in (
        ("trans", metrics.PoseRelation.translation_part),
        ("rot", metrics.PoseRelation.rotation_angle_deg),
    ):
        rpe = metrics.RPE(relation, delta=1, delta_unit=metrics.Unit.frames, all_pairs=True)
        rpe.process_data((reference, estimated))
        errors[name] = rpe.error
    estimated.align(reference)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((reference, estimated))
    errors["ate"] = ape.error
    return errors


CASES = {
    "fr1_xyz_rgbdslam": lambda: pre_associated("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-rgbdslam.txt"),
    "fr2_desk_orb": lambda: pre_associated("fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt"),
    "random_0": lambda: random_pair(0),
    "random_1": lambda: random_pair(1),
}


@pytest.mark.parametrize("case", CASES)
def test_ate_and_rpe_equal_evo(case):
    groundtruth, estimate = CASES[case]()
    expected = evo_errors(groundtruth, estimate)
    evaluation = evaluate(groundtruth, estimate, delta=1, delta_unit="frames")

    assert len(evaluation.ate.errors) == len(groundtruth)
    np.testing.assert_allclose(evaluation.ate.errors, expected["ate"], rtol=1e-9, atol=0)
    np.testing.assert_allclose(evaluation.rpe_trans.errors, expected["trans"], rtol=1e-9, atol=0)
    np.testing.assert_allclose(evaluation.rpe_rot.errors, expected["rot"], rtol=1e-9, atol=0)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("align", ["origin", "none", "sim3"])
def test_ate_under_the_other_alignments_equals_evo(case, align):
    groundtruth, estimate = CASES[case]()
    reference = PoseTrajectory3D(poses_se3=list(groundtruth.poses), timestamps=groundtruth.timestamps)
    estimated = PoseTrajectory3D(poses_se3=list(estimate.poses), timestamps=estimate.timestamps)
    if align == "origin":
        estimated.align_origin(reference)
    elif align == "sim3":
        estimated.align(reference, correct_scale=True)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((reference, estimated))
    evaluation = evaluate(groundtruth, estimate, align=align)
    # atol: under origin alignment the first pose's error is zero up to rounding (~1e-16 m).
    np.testing.assert_allclose(evaluation.ate.errors, ape.error, rtol=1e-9, atol=1e-12)
