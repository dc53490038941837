# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The IMU's exact readings, compiled: one call for all IMUs, scalar 3-vector math inside.

With numpy the same dozen (K, 3) products cost more in call overhead than the step itself
for a few IMUs (docs/performance.md); compiled, they cost about as much as one body-step.
Formulas: :mod:`rigid_sim.core.imu`.
"""

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import kernel


@kernel
def readings(q, momentum, force, torque, inertia, inertia_inv, mass, lever, gravity, field,
             omega, specific_force, magnetic):
    """Fill ``omega``, ``specific_force`` and ``magnetic`` (K, 3), body axes, of K IMUs.

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
    field : (3,) float
        Magnetic field, world, T.
    omega : (K, 3) float
        Output: angular velocity, body axes, rad/s.
    specific_force : (K, 3) float
        Output: specific force at the mount point, body axes, m/s^2.
    magnetic : (K, 3) float
        Output: ``field`` in body axes, T.
    """
    for k in range(q.shape[0]):
        turn = kin.matrix(kin.normalize(kin.orientation_row(q, k)))
        inverse = kin.entries(inertia_inv, k)
        om = kin.body_angular_velocity(turn, inverse, kin.vector(momentum, k, 0))
        turned = kin.rotate_inverse(turn, kin.vector(torque, k, 0))
        gyroscopic = kin.cross(om, kin.rotate(kin.entries(inertia, k), om))
        alpha = kin.rotate(inverse, (turned[0] - gyroscopic[0], turned[1] - gyroscopic[1],
                                     turned[2] - gyroscopic[2]))
        r = kin.vector(lever, k, 0)
        f, m = kin.vector(force, k, 0), mass[k]
        per_mass = (f[0] / m - gravity[0], f[1] / m - gravity[1], f[2] / m - gravity[2])
        weightless = kin.rotate_inverse(turn, per_mass)   # a_com - g, body axes
        tangential = kin.cross(alpha, r)
        centripetal = kin.cross(om, kin.cross(om, r))
        kin.store(omega, k, 0, om)
        kin.store(magnetic, k, 0, kin.rotate_inverse(turn, (field[0], field[1], field[2])))
        kin.store(specific_force, k, 0, (weightless[0] + tangential[0] + centripetal[0],
                                         weightless[1] + tangential[1] + centripetal[1],
                                         weightless[2] + tangential[2] + centripetal[2]))
