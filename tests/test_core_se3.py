import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from viewer_slam.geometry.se3 import (
    exp_so3,
    invert,
    make_pose,
    pose_from_tq,
    pose_to_tq,
    quat_to_rot,
    rot_to_quat,
    rotation_angle,
    slerp,
)

finite = st.floats(-10, 10, allow_nan=False)
quaternions = arrays(np.float64, 4, elements=st.floats(-1, 1, allow_nan=False)).filter(lambda q: np.linalg.norm(q) > 0.1)


@given(quaternions)
def test_quaternion_matches_scipy(q):
    np.testing.assert_allclose(quat_to_rot(q), Rotation.from_quat(q).as_matrix(), atol=1e-12)


@settings(max_examples=200)
@given(arrays(np.float64, 3, elements=st.floats(-3, 3, allow_nan=False)))
def test_rotation_quaternion_round_trip(rotvec):
    R = exp_so3(rotvec)
    np.testing.assert_allclose(R, Rotation.from_rotvec(rotvec).as_matrix(), atol=1e-12)
    q = rot_to_quat(R)
    assert q[3] >= 0
    np.testing.assert_allclose(quat_to_rot(q), R, atol=1e-12)


def test_rot_to_quat_covers_every_branch():
    angles = [np.pi, np.pi - 1e-9, 0.0, 1e-9]
    axes = np.eye(3)
    for angle in angles:
        for axis in axes:
            R = Rotation.from_rotvec(axis * angle).as_matrix()
            np.testing.assert_allclose(quat_to_rot(rot_to_quat(R)), R, atol=1e-9)


@given(arrays(np.float64, 3, elements=finite), arrays(np.float64, 3, elements=st.floats(-3, 3, allow_nan=False)))
def test_invert_is_inverse(t, rotvec):
    T = make_pose(exp_so3(rotvec), t)
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


def test_rotation_angle_and_slerp():
    q0 = rot_to_quat(np.eye(3))[None]
    q1 = rot_to_quat(exp_so3([0, 0, 1.2]))[None]
    halfway = quat_to_rot(slerp(q0, q1, np.array([0.5])))[0]
    assert np.isclose(rotation_angle(halfway), 0.6)
    assert np.isclose(rotation_angle(exp_so3([0.3, -0.4, 0])), 0.5)
    np.testing.assert_allclose(slerp(q1, q1, np.array([0.3])), q1, atol=1e-12)
