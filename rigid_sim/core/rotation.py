"""Quaternion helpers over arrays of bodies.

Quaternions are scalar-last ``(x, y, z, w)``, the order of ROS messages and of
``scipy.spatial.transform.Rotation``. These few products are written out because they
run in every integrator stage: scipy's ``Rotation`` builds an object per call, which
costs more than the arithmetic for the small N a robot scene has.
"""
import numpy as np


def multiply(p, q):
    """Hamilton product ``p q`` of quaternion arrays.

    Parameters
    ----------
    p, q : (N, 4) float
        Quaternions ``(x, y, z, w)``.

    Returns
    -------
    (N, 4) float
    """
    pv, pw = p[:, :3], p[:, 3:]
    qv, qw = q[:, :3], q[:, 3:]
    vector = pw * qv + qw * pv + np.cross(pv, qv)
    scalar = pw * qw - np.sum(pv * qv, axis=1, keepdims=True)
    return np.concatenate((vector, scalar), axis=1)


def conjugate(q):
    """Inverse of unit quaternions ``(x, y, z, w)``: (N, 4)."""
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def to_matrix(q):
    """Rotation matrices of unit quaternions.

    Parameters
    ----------
    q : (N, 4) float
        Unit quaternions ``(x, y, z, w)`` mapping body axes to world axes.

    Returns
    -------
    (N, 3, 3) float
        ``R`` with ``v_world = R @ v_body``.
    """
    x, y, z, w = q.T
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    rows = (
        (1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)),
        (2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)),
        (2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)),
    )
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def rotate(matrices, vectors):
    """``R v`` for (N, 3, 3) matrices and (N, 3) vectors."""
    return np.einsum('nij,nj->ni', matrices, vectors)


def rotate_inverse(matrices, vectors):
    """``R^T v`` for (N, 3, 3) matrices and (N, 3) vectors."""
    return np.einsum('nji,nj->ni', matrices, vectors)


def exp_map(rotation_vector):
    """Unit quaternions of rotation vectors (axis times angle), (N, 3) -> (N, 4).

    ``sin(a/2)/a`` is evaluated with ``np.sinc`` so a zero rotation needs no branch.
    """
    angle = np.linalg.norm(rotation_vector, axis=1, keepdims=True)
    half_sinc = 0.5 * np.sinc(angle / (2.0 * np.pi))
    return np.concatenate((rotation_vector * half_sinc, np.cos(0.5 * angle)), axis=1)


def normalize(q):
    """Unit quaternions, (N, 4) -> (N, 4)."""
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def angle_between(p, q):
    """Rotation angle in radians from ``p`` to ``q``, (N, 4) each -> (N,).

    ``atan2`` of the relative rotation keeps full precision for tiny angles, where
    ``arccos`` of a dot product bottoms out near 1e-8 rad.
    """
    relative = multiply(conjugate(p), q)
    return 2.0 * np.arctan2(np.linalg.norm(relative[:, :3], axis=1), np.abs(relative[:, 3]))
