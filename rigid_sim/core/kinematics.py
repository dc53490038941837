# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Compiled per-body kinematics: scalar 3-vectors, 3x3 matrices and quaternions as tuples.

The compiled kernels loop over bodies and do their math on tuples of floats, which numba
keeps in registers: a rotation matrix is the 9-tuple ``(r00, r01, ..., r22)`` (row-major,
``v_world = R v_body``), a quaternion the 4-tuple ``(x, y, z, w)``. The packed state row of a
body is ``[x, q, P, L]`` (see :mod:`rigid_sim.core.state`).
"""
import math

from rigid_sim.core.compiled import helper, kernel

# Integrators return unit quaternions. One off by more than this overflowed before it was
# normalised (to zeros: finite, but no rotation at all), and it is treated like a NaN.
UNIT_QUATERNION_SLACK = 1e-6


@helper
def matrix(q):
    """``R`` (9-tuple, row-major) of the quaternion ``q`` (x, y, z, w), Shoemake's formula.

    Exact for unit ``q``; integrator stages pass slightly non-unit ones, as RK stages are.
    """
    x, y, z, w = q
    return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w),
            2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w),
            2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y))


@helper
def rotate(r, v):
    """``R v`` for a row-major 9-tuple ``R`` (a rotation, or an inertia from :func:`entries`)."""
    return (r[0] * v[0] + r[1] * v[1] + r[2] * v[2],
            r[3] * v[0] + r[4] * v[1] + r[5] * v[2],
            r[6] * v[0] + r[7] * v[1] + r[8] * v[2])


@helper
def rotate_inverse(r, v):
    """``R^T v`` for a 9-tuple ``R`` and a 3-tuple ``v``."""
    return (r[0] * v[0] + r[3] * v[1] + r[6] * v[2],
            r[1] * v[0] + r[4] * v[1] + r[7] * v[2],
            r[2] * v[0] + r[5] * v[1] + r[8] * v[2])


@helper
def add(u, v):
    """``u + v`` of 3-tuples."""
    return (u[0] + v[0], u[1] + v[1], u[2] + v[2])


@helper
def plus_scaled(u, a, v):
    """``u + a v`` of 3-tuples ``u``, ``v`` and a float ``a``."""
    return (u[0] + a * v[0], u[1] + a * v[1], u[2] + a * v[2])


@helper
def scaled(a, v):
    """Return ``a v`` of a float ``a`` and a 3-tuple ``v``."""
    return (a * v[0], a * v[1], a * v[2])


@helper
def plus_scaled4(u, a, v):
    """``u + a v`` of 4-tuples ``u``, ``v`` and a float ``a``."""
    return (u[0] + a * v[0], u[1] + a * v[1], u[2] + a * v[2], u[3] + a * v[3])


@helper
def entries(m, i):
    """9-tuple (row-major) of the 3x3 matrix ``m[i]`` of an (N, 3, 3) array, without a view.

    A view of ``m[i]`` takes and drops a reference to ``m``'s memory each time it is made,
    a cost a kernel that makes one per body and stage pays every time (docs/performance.md,
    "A body at a time").
    """
    return (m[i, 0, 0], m[i, 0, 1], m[i, 0, 2], m[i, 1, 0], m[i, 1, 1], m[i, 1, 2],
            m[i, 2, 0], m[i, 2, 1], m[i, 2, 2])


@helper
def cross(u, v):
    """``u x v`` of 3-tuples."""
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


@helper
def dot(u, v):
    """``u . v`` of 3-tuples."""
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@helper
def multiply(p, q):
    """Hamilton product ``p q`` of 4-tuples (x, y, z, w)."""
    return (p[3] * q[0] + q[3] * p[0] + p[1] * q[2] - p[2] * q[1],
            p[3] * q[1] + q[3] * p[1] + p[2] * q[0] - p[0] * q[2],
            p[3] * q[2] + q[3] * p[2] + p[0] * q[1] - p[1] * q[0],
            p[3] * q[3] - p[0] * q[0] - p[1] * q[1] - p[2] * q[2])


@helper
def conjugate(q):
    """Inverse of a unit quaternion 4-tuple."""
    return (-q[0], -q[1], -q[2], q[3])


@helper
def normalize(q):
    """``q / |q|`` of a 4-tuple."""
    scale = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] * scale, q[1] * scale, q[2] * scale, q[3] * scale)


@helper
def exp_map(v):
    """Return the unit quaternion (x, y, z, w) of rotation vector ``v`` (axis times angle, rad)."""
    angle = math.sqrt(dot(v, v))
    half = 0.5 * angle
    # sin(a/2) / a without a branch cut at zero: its series to the round-off of the angle.
    factor = 0.5 - angle * angle / 48.0 if angle < 1e-4 else math.sin(half) / angle
    return (v[0] * factor, v[1] * factor, v[2] * factor, math.cos(half))


@helper
def orientation(y, i):
    """Quaternion 4-tuple of body ``i`` in the packed state ``y`` (N, 13)."""
    return (y[i, 3], y[i, 4], y[i, 5], y[i, 6])


@helper
def vector(a, i, start):
    """3-tuple ``a[i, start:start + 3]``."""
    return (a[i, start], a[i, start + 1], a[i, start + 2])


@helper
def store(a, i, start, v):
    """``a[i, start:start + len(v)] = v`` for a tuple ``v``."""
    for k in range(len(v)):
        a[i, start + k] = v[k]


@helper
def copy_columns(target, at, source, start, count):
    """``target[:, at:at + count] = source[:, start:start + count]`` of (N, m) arrays.

    Element by element: numba compiles an array assignment with code to format its
    shape-mismatch error, which cost more to compile than the kernels using it.
    """
    for i in range(source.shape[0]):
        for k in range(count):
            target[i, at + k] = source[i, start + k]


@helper
def body_angular_velocity(r, inertia_inv, angular_momentum):
    """``omega_b = I_body^-1 R^T L``, body axes, rad/s: the one place it is defined.

    Parameters
    ----------
    r : 9-tuple of float
        Rotation matrix ``R``, body to world, row-major.
    inertia_inv : 9-tuple of float
        Inverse body-frame inertia ``I_body^-1``, 1/(kg m^2), row-major (:func:`entries`).
    angular_momentum : 3-tuple of float
        Angular momentum ``L``, kg m^2/s, world axes.

    Returns
    -------
    3-tuple of float
        Angular velocity, rad/s, body axes.
    """
    return rotate(inertia_inv, rotate_inverse(r, angular_momentum))


@helper
def angular_velocity(r, inertia_inv, angular_momentum):
    """``omega = R I_body^-1 R^T L``, world axes, rad/s: :func:`body_angular_velocity` turned.

    The arguments are those of :func:`body_angular_velocity`.
    """
    return rotate(r, body_angular_velocity(r, inertia_inv, angular_momentum))


@kernel
def check_substep(y):
    """Check a state after a substep: 0 good, 1 non-finite, -1 a quaternion not unit.

    A quaternion off unit by more than :data:`UNIT_QUATERNION_SLACK` overflowed before it
    was normalised. ``y`` is the packed state (N, 13).
    """
    for i in range(y.shape[0]):
        for k in range(13):
            if not math.isfinite(y[i, k]):
                return 1
        q = orientation(y, i)
        if abs(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0) \
                > UNIT_QUATERNION_SLACK:
            return -1
    return 0


@helper
def body_state(y, i):
    """Return body ``i``'s ``x``, ``q``, ``P`` and ``L`` tuples from the packed state ``y``."""
    return vector(y, i, 0), orientation(y, i), vector(y, i, 7), vector(y, i, 10)


@helper
def store_body(y, i, x, q, p, big_l):
    """Write body ``i``'s ``x``, ``q``, ``P`` and ``L`` tuples into the packed state ``y``."""
    store(y, i, 0, x)
    store(y, i, 3, q)
    store(y, i, 7, p)
    store(y, i, 10, big_l)


@helper
def earlier_failure(first, code, substep):
    """Return the failure code a step reports: ``first`` (0: none) or ``code`` at ``substep``.

    ``code`` (1 or -1, see :func:`check_substep`) is a body's at 1-based ``substep``; the
    earliest substep over the bodies wins, the first body found there on ties.
    """
    if first == 0 or substep < abs(first):
        return code * substep
    return first


@helper
def check_body(x, q, p, big_l):
    """:func:`check_substep` of one body's state tuples: 0 good, 1 non-finite, -1 not unit."""
    for v in (x, p, big_l):
        for k in range(3):
            if not math.isfinite(v[k]):
                return 1
    for k in range(4):
        if not math.isfinite(q[k]):
            return 1
    if abs(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1.0) > UNIT_QUATERNION_SLACK:
        return -1
    return 0


@kernel
def largest_spin(y, inertia_inv, covered, held, everyone):
    """Largest ``|omega|``, rad/s, over the bodies ``everyone`` or ``covered | held`` selects.

    ``covered`` and ``held`` are (N,) bool: bodies always torqued, and those holding a
    wrench now.
    """
    largest = 0.0
    for i in range(y.shape[0]):
        if everyone or covered[i] or held[i]:
            body = body_angular_velocity(matrix(orientation(y, i)), entries(inertia_inv, i),
                                         vector(y, i, 10))
            largest = max(largest, dot(body, body))
    return math.sqrt(largest)


@helper
def orientation_row(q, i):
    """4-tuple ``q[i, 0:4]`` of an (N, 4) quaternion array."""
    return (q[i, 0], q[i, 1], q[i, 2], q[i, 3])
