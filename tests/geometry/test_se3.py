import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from viewer_slam.geometry.interpolation import interpolate_poses
from viewer_slam.geometry.se3 import invert, make_pose, pose_from_tq, pose_to_tq, rotation_angle
from viewer_slam.geometry.trajectory import Trajectory

finite = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=200)
@given(arrays(np.float64, 3, elements=finite), arrays(np.float64, 3, elements=st.floats(-3, 3, allow_nan=False)))
def test_pose_quaternion_round_trip_keeps_qw_non_negative(t, rotvec):
    T = make_pose(Rotation.from_rotvec(rotvec).as_matrix(), t)
    t2, q = pose_to_tq(T)
    assert q[3] >= 0
    np.testing.assert_allclose(pose_from_tq(t2, q), T, atol=1e-12)


@given(arrays(np.float64, 3, elements=finite), arrays(np.float64, 3, elements=st.floats(-3, 3, allow_nan=False)))
def test_invert_is_inverse(t, rotvec):
    T = make_pose(Rotation.from_rotvec(rotvec).as_matrix(), t)
    np.testing.assert_allclose(invert(T) @ T, np.eye(4), atol=1e-9)


def test_vectorised_pose_round_trip():
    rng = np.random.default_rng(1)
    q = rng.normal(size=(50, 4))
    t = rng.normal(size=(50, 3))
    T = pose_from_tq(t, q)
    t2, q2 = pose_to_tq(T)
    np.testing.assert_allclose(t2, t)
    np.testing.assert_allclose(pose_from_tq(t2, q2), T, atol=1e-12)
    np.testing.assert_allclose(invert(T) @ T, np.broadcast_to(np.eye(4), T.shape), atol=1e-12)


def test_rotation_angle_is_exact_from_tiny_angles_to_pi():
    for angle in (1e-12, 1e-9, 1e-3, 0.5, np.pi - 1e-9):
        R = Rotation.from_rotvec(np.array([0.48, -0.6, 0.64]) * angle).as_matrix()
        assert abs(rotation_angle(R) - angle) <= 1e-15 * max(angle, 1.0)


def test_interpolation_slerps_between_poses():
    turned = make_pose(Rotation.from_rotvec([0, 0, 1.2]).as_matrix(), [1.0, 2.0, 0.0])
    trajectory = Trajectory(np.array([0.0, 0.1]), np.stack([np.eye(4), turned]))
    poses, covered = interpolate_poses(trajectory, np.array([0.05, 0.1]))
    assert covered.all()
    np.testing.assert_allclose(
        poses[0], make_pose(Rotation.from_rotvec([0, 0, 0.6]).as_matrix(), [0.5, 1.0, 0.0]), atol=1e-12
    )
    np.testing.assert_array_equal(poses[1], turned)
