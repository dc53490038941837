# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The IMU's exact readings, compiled: one call for all IMUs, scalar 3-vector math inside.

With numpy the same dozen (K, 3) products cost more in call overhead than the step itself
for a few IMUs (docs/performance.md); compiled, they cost about as much as one body-step.
Formulas: :mod:`rigid_sim.core.imu`.
"""
import math

import numpy as np
from numba import njit


@njit(cache=True)
def _matrix(q):
    """Body-to-world rotation matrix of the quaternion (x, y, z, w), normalised first."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    x, y, z, w = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    r = np.empty((3, 3))
    r[0, 0], r[0, 1], r[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    r[1, 0], r[1, 1], r[1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    r[2, 0], r[2, 1], r[2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    return r


@njit(cache=True)
def _cross(a, b):
    return np.array((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]))


@njit(cache=True)
def readings(q, momentum, force, torque, inertia, inertia_inv, mass, lever, gravity,
             omega, specific_force):
    """Fill ``omega`` and ``specific_force`` (K, 3), body axes, of K IMUs.

    Parameters
    ----------
    q : (K, 4) float
        Orientations (x, y, z, w), body to world.
    momentum : (K, 3) float
        Angular momentum L, world, kg m^2/s.
    force : (K, 3) float
        Net force, world, N.
    torque : (K, 3) float
        Net torque about the centre of mass, world, N m.
    inertia : (K, 3, 3) float
        Inertia about the centre of mass, body axes, kg m^2.
    inertia_inv : (K, 3, 3) float
        Its inverse.
    mass : (K,) float
        kg.
    lever : (K, 3) float
        Mount point minus centre of mass, body axes, m.
    gravity : (3,) float
        Gravitational acceleration, world, m/s^2.
    omega : (K, 3) float
        Output: angular velocity, body axes, rad/s.
    specific_force : (K, 3) float
        Output: specific force at the mount point, body axes, m/s^2.
    """
    for k in range(q.shape[0]):
        turn = _matrix(q[k])
        back = turn.T.copy()
        om = inertia_inv[k] @ (back @ momentum[k])
        alpha = inertia_inv[k] @ (back @ torque[k] - _cross(om, inertia[k] @ om))
        r = lever[k]
        omega[k] = om
        specific_force[k] = (back @ (force[k] / mass[k] - gravity) + _cross(alpha, r)
                             + _cross(om, _cross(om, r)))
