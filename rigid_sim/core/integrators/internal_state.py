# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The state inside an explicit step: Baraff's, or with body-axes angular momentum.

Baraff's world-axes ``L`` has ``omega = R I_body^-1 R^T L`` depend on ``q``, so every error
in ``q`` feeds back into ``omega`` and grows. Body-axes ``L_b = R^T L`` has
``omega_b = I_body^-1 L_b`` independent of ``q`` (Euler's equations), so near the
intermediate axis RK4 in body axes is orders of magnitude more accurate at the same step.
The public state stays Baraff's; only the inside of a step changes: with ``body_axes``,
slots 10:13 of the internal state hold ``L_b``. A slope (dx, dq, dP, dL) has the state's
layout. The Runge-Kutta kernels and ``dopri5``'s right-hand side share these.
"""
from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper


@helper
def to_internal(y, start, body_axes):
    """``start`` = ``y``, with ``L_b = R^T L`` in slots 10:13 when ``body_axes``."""
    kin.copy_columns(start, 0, y, 0, 13)
    if body_axes:
        for i in range(y.shape[0]):
            r = kin.matrix(kin.orientation(y, i))
            kin.store(start, i, 10, kin.rotate_inverse(r, kin.vector(y, i, 10)))


@helper
def derivative(q, momentum, angular, force, torque, inertia_inv, inverse_mass, body_axes):
    """``d/dt`` of a body's internal state: (dx, dq, dP, dL) tuples.

    ``q`` and ``momentum`` are the stage's quaternion and linear momentum, ``angular`` its
    internal angular momentum (``L_b`` when ``body_axes``, else world ``L``); ``force`` and
    ``torque`` the net wrench, world axes; ``inertia_inv`` the body's ``I_body^-1`` as a
    9-tuple (:func:`~rigid_sim.core.kinematics.entries`), ``inverse_mass`` its ``1 / M``.
    """
    r = kin.matrix(q)
    if body_axes:
        omega_body = kin.rotate(inertia_inv, angular)
        dq = kin.multiply(q, (omega_body[0], omega_body[1], omega_body[2], 0.0))
        turned = kin.rotate_inverse(r, torque)
        gyroscopic = kin.cross(angular, omega_body)   # L_b x omega_b = -omega_b x L_b
        dl = kin.add(turned, gyroscopic)
    else:
        omega = kin.angular_velocity(r, inertia_inv, angular)
        dq = kin.multiply((omega[0], omega[1], omega[2], 0.0), q)
        dl = torque
    dx = (momentum[0] * inverse_mass, momentum[1] * inverse_mass, momentum[2] * inverse_mass)
    return dx, (0.5 * dq[0], 0.5 * dq[1], 0.5 * dq[2], 0.5 * dq[3]), force, dl


@helper
def slope_of(world, momentum, model, force, torque, body_axes, i):
    """:func:`derivative` of body ``i`` of a stage held in arrays.

    ``world`` (N, 13) holds the stage in world axes, ``momentum`` (N, 3) its internal
    angular momentum.
    """
    return derivative(kin.orientation(world, i), kin.vector(world, i, 7),
                      kin.vector(momentum, i, 0), kin.vector(force, i, 0),
                      kin.vector(torque, i, 0), kin.entries(model.inertia_inv, i),
                      model.inverse_mass[i], body_axes)


@helper
def set_stage(start, i, step, slope, world, momentum, body_axes):
    """Body ``i`` of the stage ``start + step slope``, into ``world`` and ``momentum``."""
    dx, dq, dp, dl = slope
    for k in range(3):
        world[i, k] = start[i, k] + step * dx[k]
        world[i, 7 + k] = start[i, 7 + k] + step * dp[k]
        momentum[i, k] = start[i, 10 + k] + step * dl[k]
    for k in range(4):
        world[i, 3 + k] = start[i, 3 + k] + step * dq[k]
    angular = kin.vector(momentum, i, 0)
    if body_axes:
        angular = kin.rotate(kin.matrix(kin.orientation(world, i)), angular)
    kin.store(world, i, 10, angular)


@helper
def add_slope(y, i, weight, slope):
    """``y[i] += weight slope`` in the internal layout."""
    dx, dq, dp, dl = slope
    for k in range(3):
        y[i, k] += weight * dx[k]
        y[i, 7 + k] += weight * dp[k]
        y[i, 10 + k] += weight * dl[k]
    for k in range(4):
        y[i, 3 + k] += weight * dq[k]


@helper
def to_public(y, body_axes):
    """Normalise the quaternions and turn ``L_b`` (slots 10:13) into world-axes ``L``, in place."""
    for i in range(y.shape[0]):
        q = kin.normalize(kin.orientation(y, i))
        kin.store(y, i, 3, q)
        if body_axes:
            kin.store(y, i, 10, kin.rotate(kin.matrix(q), kin.vector(y, i, 10)))
