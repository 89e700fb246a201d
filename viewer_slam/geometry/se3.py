"""SE(3) helpers on 4x4 float64 matrices, vectorised over leading axes.

A pose is ``T_world_camera`` (camera to world). Quaternions are ``(qx, qy, qz, qw)``,
scalar last, as in TUM trajectory files.
"""

import numpy as np


def quat_to_rot(q: np.ndarray) -> np.ndarray:
    """Rotation matrices from quaternions ``(..., 4)`` in xyzw order (normalised here)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = np.moveaxis(q, -1, 0)
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - z * w)
    R[..., 0, 2] = 2 * (x * z + y * w)
    R[..., 1, 0] = 2 * (x * y + z * w)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - x * w)
    R[..., 2, 0] = 2 * (x * z - y * w)
    R[..., 2, 1] = 2 * (y * z + x * w)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def rot_to_quat(R: np.ndarray) -> np.ndarray:
    """Quaternions ``(..., 4)`` xyzw with ``qw >= 0`` from rotation matrices ``(..., 3, 3)``.

    Uses the numerically stable branch per element (largest diagonal term).
    """
    R = np.asarray(R, dtype=np.float64)
    m = R.reshape(-1, 3, 3)
    trace = np.trace(m, axis1=1, axis2=2)
    diag = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    candidates = np.concatenate([trace[:, None], diag], axis=1)
    branch = np.argmax(candidates, axis=1)
    q = np.empty((len(m), 4))
    for b in range(4):
        s = branch == b
        if not s.any():
            continue
        r = m[s]
        if b == 0:
            k = np.sqrt(1.0 + trace[s]) * 2
            q[s] = np.stack([(r[:, 2, 1] - r[:, 1, 2]) / k, (r[:, 0, 2] - r[:, 2, 0]) / k,
                             (r[:, 1, 0] - r[:, 0, 1]) / k, 0.25 * k], axis=1)
        elif b == 1:
            k = np.sqrt(1.0 + r[:, 0, 0] - r[:, 1, 1] - r[:, 2, 2]) * 2
            q[s] = np.stack([0.25 * k, (r[:, 0, 1] + r[:, 1, 0]) / k,
                             (r[:, 0, 2] + r[:, 2, 0]) / k, (r[:, 2, 1] - r[:, 1, 2]) / k], axis=1)
        elif b == 2:
            k = np.sqrt(1.0 + r[:, 1, 1] - r[:, 0, 0] - r[:, 2, 2]) * 2
            q[s] = np.stack([(r[:, 0, 1] + r[:, 1, 0]) / k, 0.25 * k,
                             (r[:, 1, 2] + r[:, 2, 1]) / k, (r[:, 0, 2] - r[:, 2, 0]) / k], axis=1)
        else:
            k = np.sqrt(1.0 + r[:, 2, 2] - r[:, 0, 0] - r[:, 1, 1]) * 2
            q[s] = np.stack([(r[:, 0, 2] + r[:, 2, 0]) / k, (r[:, 1, 2] + r[:, 2, 1]) / k,
                             0.25 * k, (r[:, 1, 0] - r[:, 0, 1]) / k], axis=1)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[q[:, 3] < 0] *= -1
    return q.reshape(R.shape[:-2] + (4,))


def make_pose(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """4x4 poses from rotations ``(..., 3, 3)`` and translations ``(..., 3)``."""
    R = np.asarray(R, dtype=np.float64)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def pose_from_tq(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """4x4 poses from translations ``(..., 3)`` and xyzw quaternions ``(..., 4)``."""
    return make_pose(quat_to_rot(q), t)


def pose_to_tq(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translations ``(..., 3)`` and xyzw quaternions ``(..., 4)`` of 4x4 poses."""
    T = np.asarray(T, dtype=np.float64)
    return T[..., :3, 3].copy(), rot_to_quat(T[..., :3, :3])


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of rigid 4x4 transforms, using R^T rather than a general inverse."""
    T = np.asarray(T, dtype=np.float64)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    return make_pose(Rt, -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3]))


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply one 4x4 transform to points ``(N, 3)``."""
    return points @ T[:3, :3].T + T[:3, 3]


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Rotation angle in radians of rotation matrices ``(..., 3, 3)``, in [0, pi].

    atan2 of the sine (from the skew part) and cosine (from the trace) parts stays accurate
    for the tiny rotations between frames, where arccos of the trace loses half the digits.
    """
    R = np.asarray(R)
    skew = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    sine = 0.5 * np.linalg.norm(skew, axis=-1)
    cosine = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sine, cosine)


def slerp(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Spherical interpolation between xyzw quaternions ``(N, 4)`` at fractions ``s`` ``(N,)``."""
    q0 = q0 / np.linalg.norm(q0, axis=-1, keepdims=True)
    q1 = q1 / np.linalg.norm(q1, axis=-1, keepdims=True)
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where(dot[..., None] < 0, -q1, q1)
    dot = np.abs(dot)
    s = np.asarray(s, dtype=np.float64)[..., None]
    theta = np.arccos(np.clip(dot, -1.0, 1.0))[..., None]
    sin = np.sin(theta)
    near = sin < 1e-9
    safe = np.where(near, 1.0, sin)
    w0 = np.where(near, 1.0 - s, np.sin((1.0 - s) * theta) / safe)
    w1 = np.where(near, s, np.sin(s * theta) / safe)
    q = w0 * q0 + w1 * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def exp_so3(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrix from a rotation vector (axis times angle), Rodrigues' formula."""
    rotvec = np.asarray(rotvec, dtype=np.float64)
    angle = np.linalg.norm(rotvec)
    if angle < 1e-12:
        return np.eye(3)
    k = rotvec / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
