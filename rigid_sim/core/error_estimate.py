# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Local error estimates in one unit: the relative error of a body's scaled state.

Every integrator estimates, inside its compiled kernel, how far each body's state after a
step is from the exact solution that starts where the step started, and reports it per body
as the largest over the state's components of ``|error_k| / scale_k``. The scales are a
body's own sizes, those :class:`~rigid_sim.core.integrators.adaptive.Dopri5` holds its
tolerance to, so a microgram body is judged as strictly as a kilogram one:

================  ===========================================================================
position          the radius of gyration, ``sqrt(trace(I_body) / M)``
quaternion        1
linear momentum   ``|P|``, or at rest ``M`` times the radius of gyration per step ``dt``
angular momentum  ``|L|``, or at rest ``trace(I_body) / dt``
================  ===========================================================================

An estimate of 1e-6 thus means: the body is off by a millionth of its size, of a radian
(twice the quaternion's error), or of its momentum. How each family estimates is in its
module; the estimates are checked against the true error in docs/accuracy.md ("Error
estimates").
"""
import math

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper, kernel


@helper
def body_scales(model, i, p, big_l, dt):
    """Position, linear and angular momentum scales of body ``i`` (see the module's table).

    ``p`` and ``big_l`` are its momenta (3-tuples), ``dt`` (s) the step the body moves in.
    """
    length = model.gyration[i]
    inertia = model.mass[i] * length * length
    momentum = max(math.sqrt(kin.dot(p, p)), model.mass[i] * length / dt)
    angular = max(math.sqrt(kin.dot(big_l, big_l)), inertia / dt)
    return length, momentum, angular


@kernel
def state_scales(model, y, dt, out):
    """Per-component scales of the state ``y`` (N, 13) for a step ``dt``, into ``out`` (N, 13)."""
    for i in range(y.shape[0]):
        length, momentum, angular = body_scales(model, i, kin.vector(y, i, 7),
                                                kin.vector(y, i, 10), dt)
        kin.store_body(out, i, (length, length, length), (1.0, 1.0, 1.0, 1.0),
                       (momentum, momentum, momentum), (angular, angular, angular))
    return out


@helper
def store_scales(y, model, dt, scales):
    """Every body's :func:`body_scales` at the state ``y`` for a step ``dt``, into (N, 3)."""
    for i in range(y.shape[0]):
        kin.store(scales, i, 0, body_scales(model, i, kin.vector(y, i, 7),
                                            kin.vector(y, i, 10), dt))


@helper
def turning_part(dq, q):
    """Return the part of a quaternion error ``dq`` that turns the unit ``q``: dq - (dq.q) q.

    The rest changes only its length, which every step's normalisation takes away.
    """
    along = dq[0] * q[0] + dq[1] * q[1] + dq[2] * q[2] + dq[3] * q[3]
    return (dq[0] - along * q[0], dq[1] - along * q[1], dq[2] - along * q[2],
            dq[3] - along * q[3])


@helper
def quaternion_error(angle, q):
    """Return the error of the unit quaternion ``q`` turned by a small ``angle`` (world, rad).

    ``(angle, 0) q / 2``, the first-order change of ``q``.
    """
    return kin.multiply((0.5 * angle[0], 0.5 * angle[1], 0.5 * angle[2], 0.0), q)


@helper
def scaled_size(dx, dq, dp, dl, scales):
    """Largest component of the error (``dx``, ``dq``, ``dp``, ``dl`` tuples) over its scale."""
    length, momentum, angular = scales
    position = max(abs(dx[0]), abs(dx[1]), abs(dx[2])) / length
    turn = max(abs(dq[0]), abs(dq[1]), abs(dq[2]), abs(dq[3]))
    linear = max(abs(dp[0]), abs(dp[1]), abs(dp[2])) / momentum
    return max(position, turn, linear, max(abs(dl[0]), abs(dl[1]), abs(dl[2])) / angular)


@kernel
def scaled_errors(model, reference, y, dt, out):
    """Per-body scaled size of ``y - reference`` (both (N, 13)), written into ``out`` (N,).

    The scales are those of ``reference`` with step ``dt`` (s); a quaternion is compared
    with the sign of the reference's (``q`` and ``-q`` are one rotation).
    """
    for i in range(y.shape[0]):
        x0, q0, p0, l0 = kin.body_state(reference, i)
        x, q, p, big_l = kin.body_state(y, i)
        sign = 1.0 if q[0] * q0[0] + q[1] * q0[1] + q[2] * q0[2] + q[3] * q0[3] >= 0 else -1.0
        out[i] = scaled_size(kin.plus_scaled(x, -1.0, x0), kin.plus_scaled4(q0, -sign, q),
                             kin.plus_scaled(p, -1.0, p0), kin.plus_scaled(big_l, -1.0, l0),
                             body_scales(model, i, p0, l0, dt))
    return out


@kernel
def rotational_invariants(y, inertia_inv, out):
    """Each body's ``|L|`` and rotational energy ``L . omega / 2`` into ``out`` (N, 2).

    A body nothing torques keeps both exactly; their drift is the integration's error.
    """
    for i in range(y.shape[0]):
        big_l = kin.vector(y, i, 10)
        omega = kin.angular_velocity(kin.matrix(kin.orientation(y, i)),
                                     kin.entries(inertia_inv, i), big_l)
        out[i, 0] = math.sqrt(kin.dot(big_l, big_l))
        out[i, 1] = 0.5 * kin.dot(big_l, omega)
    return out


def true_errors(bodies, reference, y, dt):
    """(N,) scaled error of the state ``y`` against ``reference`` ((N, 13) each), step ``dt``."""
    return scaled_errors(bodies.model, np.ascontiguousarray(reference, dtype=float),
                         np.ascontiguousarray(y, dtype=float), float(dt),
                         np.empty(bodies.count))
