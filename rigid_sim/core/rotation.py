# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Quaternion helpers over arrays of bodies.

Quaternions are scalar-last ``(x, y, z, w)``, the order of ROS messages and of
``scipy.spatial.transform.Rotation``. These few products are written out because they
run in every integrator stage: scipy's ``Rotation`` builds an object per call, which
costs more than the arithmetic for the small N a robot scene has.

Two layouts are served. The public functions take body-major arrays, one row per body:
``(N, 4)`` quaternions, ``(N, 3)`` vectors, ``(N, 3, 3)`` matrices. The ``*_rows`` functions
take component-major arrays, one row per component: ``(4, N)``, ``(3, N)``, ``(3, 3, N)``;
snapshots use them because each row is a contiguous run of N numbers, so one numpy call
serves every body and a row never has to be gathered from N strided places. The step
itself runs compiled, on :mod:`rigid_sim.core.kinematics`.
"""
import numpy as np

# v_j of a cross product u x v pairs with u_i for (i, j) = (1, 2), (2, 0), (0, 1) ...
_NEXT = np.array([1, 2, 0])
# ... minus the pairs (2, 1), (0, 2), (1, 0).
_PREVIOUS = np.array([2, 0, 1])
# R = I + sum over the two products of each entry, as flat indices into the outer product
# q q^T (4 x 4) and their coefficients (Shoemake's formula, valid for unit q).
_FIRST = np.array([5, 4, 8, 4, 0, 9, 8, 9, 0])
_FIRST_SIGN = np.array([-2.0, 2.0, 2.0, 2.0, -2.0, 2.0, 2.0, 2.0, -2.0])[:, None]
_SECOND = np.array([10, 14, 13, 14, 10, 12, 13, 12, 5])
_SECOND_SIGN = np.array([-2.0, -2.0, 2.0, 2.0, -2.0, -2.0, -2.0, 2.0, -2.0])[:, None]
_IDENTITY = np.eye(3).reshape(9, 1)


def matrix_rows(q, out=None, work=None):
    """Rotation matrices of quaternion rows.

    Parameters
    ----------
    q : (4, N) float
        Unit quaternions ``(x, y, z, w)``, one component per row.
    out : (3, 3, N) float, optional
        Where to write the result.
    work : (25, N) float, optional
        Scratch space; reusing it spares large N a fresh allocation (page faults) per call.

    Returns
    -------
    (3, 3, N) float
        ``R[i, j]`` over the bodies, with ``v_world = R v_body``.
    """
    count = q.shape[1]
    work = np.empty((25, count)) if work is None else work
    out = np.empty((3, 3, count)) if out is None else out
    products, second = work[:16], work[16:]
    np.multiply(q[:, None], q[None], out=products.reshape(4, 4, count))
    flat = out.reshape(9, count)
    # mode='clip' writes straight into ``out``; 'raise' would buffer a copy first.
    products.take(_FIRST, axis=0, out=flat, mode='clip')
    flat *= _FIRST_SIGN
    products.take(_SECOND, axis=0, out=second, mode='clip')
    second *= _SECOND_SIGN
    flat += second
    flat += _IDENTITY
    return out


def rotate_rows(matrices, vectors, out=None):
    """``R v`` for (3, 3, N) matrices and (3, N) vectors: (3, N)."""
    return np.einsum('ijn,jn->in', matrices, vectors, out=out)


def cross_rows(u, v, out=None, work=None):
    """``u x v`` for (3, N) vector rows: (3, N); ``work`` is optional (6, N) scratch."""
    count = u.shape[1]
    work = np.empty((6, count)) if work is None else work
    out = np.empty((3, count)) if out is None else out
    first, second = work[:3], work[3:]
    u.take(_NEXT, axis=0, out=first, mode='clip')
    v.take(_PREVIOUS, axis=0, out=out, mode='clip')
    out *= first
    u.take(_PREVIOUS, axis=0, out=first, mode='clip')
    v.take(_NEXT, axis=0, out=second, mode='clip')
    first *= second
    out -= first
    return out


def multiply_rows(p, q):
    """Hamilton product ``p q`` of quaternion rows (4, N) each: (4, N)."""
    product = np.empty(np.broadcast_shapes(p.shape, q.shape))
    product[:3] = p[3] * q[:3] + q[3] * p[:3] + np.cross(p[:3], q[:3], axis=0)
    product[3] = p[3] * q[3] - np.einsum('in,in->n', p[:3], q[:3])
    return product


def normalize_rows(q, out=None):
    """Return unit quaternion rows, (4, N) -> (4, N)."""
    return np.divide(q, np.sqrt(np.einsum('in,in->n', q, q)), out=out)


def exp_map_rows(rotation_vector):
    """Return unit quaternion rows of rotation-vector rows (axis times angle), (3, N) -> (4, N).

    ``sin(a/2)/a`` is evaluated with ``np.sinc`` so a zero rotation needs no branch.
    """
    angle = np.sqrt(np.einsum('in,in->n', rotation_vector, rotation_vector))
    result = np.empty((4, angle.size))
    np.multiply(rotation_vector, 0.5 * np.sinc(angle / (2.0 * np.pi)), out=result[:3])
    np.cos(0.5 * angle, out=result[3])
    return result


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
    return multiply_rows(np.asarray(p).T, np.asarray(q).T).T


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
        ``R`` with ``v_world = R @ v_body`` (a view of the component-major result).
    """
    return matrix_rows(np.asarray(q).T).transpose(2, 0, 1)


def rotate(matrices, vectors):
    """``R v`` for (N, 3, 3) matrices and (N, 3) vectors."""
    return np.einsum('nij,nj->ni', matrices, vectors)


def rotate_inverse(matrices, vectors):
    """``R^T v`` for (N, 3, 3) matrices and (N, 3) vectors."""
    return np.einsum('nji,nj->ni', matrices, vectors)


def exp_map(rotation_vector):
    """Return unit quaternions of rotation vectors (axis times angle), (N, 3) -> (N, 4)."""
    return exp_map_rows(np.asarray(rotation_vector).T).T


def normalize(q):
    """Return unit quaternions, (N, 4) -> (N, 4)."""
    return normalize_rows(np.asarray(q).T).T


def angle_between(p, q):
    """Rotation angle in radians from ``p`` to ``q``, (N, 4) each -> (N,).

    ``atan2`` of the relative rotation keeps full precision for tiny angles, where
    ``arccos`` of a dot product bottoms out near 1e-8 rad.
    """
    relative = multiply(conjugate(p), q)
    return 2.0 * np.arctan2(np.linalg.norm(relative[:, :3], axis=1), np.abs(relative[:, 3]))
