# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Splitting methods: kick the momenta with the wrench, drift with the free motion.

One Strang step of ``h`` is

1. half kick: ``P += F h/2``, ``L += tau h/2`` (world axes, wrench at the current state);
2. drift: ``x += h P/M`` and the torque-free rotation of every body for ``h``;
3. half kick with the wrench at the new state.

The drift is the free rigid body's exact motion for the translation and, for the rotation,
either the Dullweber-Leimkuhler-McLachlan (DLM) sequence of rotations about principal axes
(symplectic, ``|L|`` exact, energy bounded) or the closed-form flow of
:mod:`~rigid_sim.core.integrators.free_rotation`. Both work in principal axes, so a body
whose inertia is not diagonal in its own frame is turned into its principal frame and back.
The Yoshida triple jump composes three Strang steps into a fourth-order method.

A kick holds x and q fixed. When no effect depends on the momenta its force is constant
over the kick, which one evaluation integrates exactly. A damper makes the kick an ODE of
its own; one explicit step would cut the whole method to first order, so the kick is then
integrated by an explicit Runge-Kutta method of the splitting's own order.

Error estimate. A Strang step with a drift of ``h`` errs in position by ``h^3/6`` times the
rate of change of the acceleration (the Stormer-Verlet local error), which the two kicks
around the drift measure: ``(h^2/6) (F_after - F_before) / M``; likewise the orientation by
``(h^2/6) I^-1 (tau_after - tau_before)``, an angle. Both are free: the kicks evaluate those
wrenches anyway. The exact flow adds nothing: its error is round-off, which the estimate
omits (``estimate_omits``; on a thin rod, I = 1e-4, 1, 1.0001, spun about its middle axis,
it reached 3.6e-11 a step). The DLM drift adds its own leading local error, a closed form in
``L`` and the moments (:func:`dlm_error`), a polynomial that costs a fortieth of the exact
flow; a drift too long for that term to hold is compared with the exact flow instead.
The momenta's error, ``h^3/12`` times the acceleration's second derivative, is of the same
size as the position's (a spring: a half of it, in scaled units) and is not estimated.

A Yoshida composition is estimated by Richardson instead: the sub-steps' terms, added with
their signs, went as h^3, h^4 or h^5 by the forces while the composition errs as h^5. The
step is taken again from the same start as two of half its length; its error is 16/15 of
the difference. Only the step of ``h`` is kept, so the motion is the same with or without
the estimate, which costs two more steps and is skipped when nothing reads it.
"""
import math

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core import safeguards
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.dispatch import across_threads, CompiledCall
from rigid_sim.core.effects.base import accumulate, acts_per_body, body_wrench
from rigid_sim.core.error_estimate import (body_scales, quaternion_error, scaled_size,
                                           store_scales)
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.free_rotation import free_flow
from rigid_sim.core.integrators.runge_kutta import (CLASSICAL_RK4, EXPLICIT_MIDPOINT,
                                                    FORWARD_EULER)
from rigid_sim.core.integrators.substeps import substeps_checked

# Yoshida (1990) weights: w1 + w0 + w1 = 1 and w1^3 + w0^3 + w1^3 = 0 cancel the h^3 error.
YOSHIDA_OUTER = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
YOSHIDA_INNER = 1.0 - 2.0 * YOSHIDA_OUTER
DLM_DRIFT, EXACT_DRIFT = 0, 1   # which free rotation a kernel drifts with
# The largest ``|h| |L| / min I`` (rad) of a DLM drift up to which its error is estimated by
# its leading term (:func:`dlm_error`); beyond, the drift is compared with the exact flow (five
# times the cost of the drift). The terms the leading one omits carry a further ``1 / I_k``
# each, so the turn that bounds them is the total momentum over the smallest moment, not the
# turn about any one axis: a thin rod (I = 1e-4, 1, 1.0001) spun at 100 rad/s about its middle
# axis turns 0.1 rad a millisecond about it, yet its leading term was 0.002 to 0.007 of the
# true error there (|h| |L| / I_1 = 1000). Below the bound the term came within a factor 2.2
# of the true error on the asymmetric bodies tried.
LEADING_TERM_ANGLE = 0.1


@helper
def _dlm_axis(momentum, q, axis, theta):
    """``L_b`` turned by ``-theta`` and ``q`` by ``+theta`` about principal axis ``axis``."""
    cos, sin = math.cos(theta), math.sin(theta)
    half_cos, half_sin = math.cos(0.5 * theta), math.sin(0.5 * theta)
    # q <- q (sin(theta/2) e, cos(theta/2)) = cos q + sin q (e, 0).
    e = (half_sin if axis == 0 else 0.0, half_sin if axis == 1 else 0.0,
         half_sin if axis == 2 else 0.0, 0.0)
    turned = kin.multiply(q, e)
    q = (q[0] * half_cos + turned[0], q[1] * half_cos + turned[1],
         q[2] * half_cos + turned[2], q[3] * half_cos + turned[3])
    # A plane rotation of the two other components of L_b.
    m = momentum
    if axis == 0:
        return (m[0], m[1] * cos + m[2] * sin, m[2] * cos - m[1] * sin), q
    if axis == 1:
        return (m[0] * cos - m[2] * sin, m[1], m[2] * cos + m[0] * sin), q
    return (m[0] * cos + m[1] * sin, m[1] * cos - m[0] * sin, m[2]), q


@helper
def dlm_rotation(moments, momentum, q, h):
    """Free rotation for ``h`` as rotations about principal axes 1, 2, 3, 2, 1 (DLM 1997).

    Each sub-flow keeps ``T_i = L_i^2 / 2 I_i``: ``L_b`` turns by ``-theta`` and ``q`` by
    ``+theta`` about axis i, ``theta = L_i t / I_i``. Symmetric composition: order 2.
    ``moments``, ``momentum`` 3-tuples (principal axes), ``q`` 4-tuple principal axes to
    world.
    """
    for axis, fraction in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        momentum, q = _dlm_axis(momentum, q, axis,
                                (fraction * h) * momentum[axis] / moments[axis])
    return momentum, q


@helper
def dlm_error(inverse_moments, momentum, q, h):
    """Leading local error of :func:`dlm_rotation` against the exact flow: ``L_b`` and ``q``.

    The DLM drift is Strang's composition of the flows of ``T_1`` and of the Strang step of
    ``T_2`` and ``T_3``, so (Baker-Campbell-Hausdorff) it is the exact flow for ``h`` of
    ``T + h^2 H_3 + O(h^4)``, ``T23 = T_2 + T_3``:

    ``H_3 = {T23,{T23,T_1}}/12 - {T_1,{T_1,T23}}/24 + {T_3,{T_3,T_2}}/12 - {T_2,{T_2,T_3}}/24``

    in the Lie-Poisson bracket ``{F, G} = L_b . (grad F x grad G)`` (a double bracket keeps
    the sign either way). With ``{T_i, T_j} = L_1 L_2 L_3 / (I_i I_j)`` and
    ``{T_1, L_1 L_2 L_3} = L_1^2 (L_3^2 - L_2^2) / I_1`` (both cyclic), ``H_3`` is
    ``(c12 u1 u2 + c13 u1 u3 + c23 u2 u3) / 24`` in ``u_k = L_k^2``. Its flow for ``h`` errs
    by ``h^3 L_b x g`` and ``h^3 q (g, 0) / 2``, ``g = grad H_3`` (a body rate); the rest is
    ``O(h^4)``. ``inverse_moments`` (3-tuple) are ``1 / I_k``, the rest as for
    :func:`dlm_rotation`; returns the two errors (3- and 4-tuples, the latter a pure turn).
    """
    r1, r2, r3 = inverse_moments
    a, b = r1 * (r2 - r3), r2 * r3
    c12 = a * (r1 - 2.0 * r2) - b * r2
    c13 = a * (2.0 * r3 - r1) + 2.0 * b * r3
    c23 = 2.0 * a * (r2 - r3) + b * (r2 - 2.0 * r3)
    m = momentum
    u1, u2, u3 = m[0] * m[0], m[1] * m[1], m[2] * m[2]
    cube = h * h * h * (1.0 / 12.0)   # 2 / 24: the gradient of u_k, and H_3's denominator
    g = (cube * m[0] * (c12 * u2 + c13 * u3), cube * m[1] * (c12 * u1 + c23 * u3),
         cube * m[2] * (c13 * u1 + c23 * u2))
    return kin.cross(m, g), kin.multiply(q, (0.5 * g[0], 0.5 * g[1], 0.5 * g[2], 0.0))


@helper
def _dlm_drift(moments, momentum, q, h):
    """:func:`dlm_rotation` for ``h``, and its local error (``L_b`` and ``q`` tuples).

    The leading term (:func:`dlm_error`) while ``|h| |L| / min I`` is at most
    LEADING_TERM_ANGLE, else the difference to the exact flow.
    """
    turned, q_turned = dlm_rotation(moments, momentum, q, h)
    inverse = (1.0 / moments[0], 1.0 / moments[1], 1.0 / moments[2])
    widest = abs(h) * math.sqrt(kin.dot(momentum, momentum)) * max(inverse[0], inverse[1],
                                                                   inverse[2])
    if widest <= LEADING_TERM_ANGLE:
        return turned, q_turned, dlm_error(inverse, momentum, q, h)
    exact_momentum, exact_q = free_flow(moments, momentum, q, h)
    return turned, q_turned, (kin.plus_scaled(turned, -1.0, exact_momentum),
                              kin.plus_scaled4(q_turned, -1.0, exact_q))


@helper(inline='always')
def _drift_body(x, q, p, big_l, inverse_mass, principal, moments, h, drift, estimated):
    """One body's free motion for ``h``: its new ``x``, ``q``, world ``L`` and drift error.

    Straight-line translation and torque-free rotation. ``principal`` (4-tuple) turns the
    principal axes into the body frame, ``moments`` (3-tuple) are the principal moments.
    The error is the DLM rotation's local error (:func:`_dlm_drift`), principal axes (``L``
    and ``q`` tuples); zero for the exact flow, and when not ``estimated``: the error's
    fallback to the exact flow would cost five drifts. Scalars and tuples only: no array
    passes, so a call costs no reference counting.
    """
    x = (x[0] + p[0] * (h * inverse_mass), x[1] + p[1] * (h * inverse_mass),
         x[2] + p[2] * (h * inverse_mass))
    # Bodies whose frames are already principal skip two quaternion products.
    identity = principal == (0.0, 0.0, 0.0, 1.0)
    if not identity:
        q = kin.multiply(q, principal)
    momentum = kin.rotate_inverse(kin.matrix(q), big_l)
    error_l, error_q = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0)
    if drift == EXACT_DRIFT:
        momentum, q = free_flow(moments, momentum, q, h)
    elif estimated:
        momentum, q, (error_l, error_q) = _dlm_drift(moments, momentum, q, h)
    else:
        momentum, q = dlm_rotation(moments, momentum, q, h)
    big_l = kin.rotate(kin.matrix(q), momentum)
    if not identity:
        q = kin.multiply(q, kin.conjugate(principal))
    return x, q, big_l, (error_l, error_q)


@helper
def _kick_error(q, inverse_mass, inertia_inv, h, force, torque, force_before, torque_before):
    """Position and angle errors (3-tuples) of a drift of ``h`` between two kicks.

    ``force`` and ``torque`` are the wrench of the kick after it, ``*_before`` of the one
    before; ``q`` the orientation between (4-tuple), ``inertia_inv`` the body's 9-tuple.
    """
    c = h * h / 6.0
    position = kin.scaled(c * inverse_mass, kin.plus_scaled(force, -1.0, force_before))
    turned = kin.scaled(c, kin.plus_scaled(torque, -1.0, torque_before))
    return position, kin.angular_velocity(kin.matrix(q), inertia_inv, turned)


@helper
def _substep_error(q, position, angle, drift_error, scales):
    """Scaled size of a substep's error: estimate terms added up over its kicks and drifts.

    ``angle`` (world axes, rad) becomes the quaternion's error (:func:`quaternion_error`).
    """
    turn = kin.plus_scaled4(quaternion_error(angle, q), 1.0, drift_error[1])
    return scaled_size(position, turn, (0.0, 0.0, 0.0), drift_error[0], scales)


@helper(inline='always')
def _drift(y, model, h, drift, estimate, estimated):
    """Free motion for ``h`` of every body, in place; DLM's error added into ``estimate``."""
    for i in range(y.shape[0]):
        x, q, big_l, error = _drift_body(
            kin.vector(y, i, 0), kin.orientation(y, i), kin.vector(y, i, 7),
            kin.vector(y, i, 10), model.inverse_mass[i], kin.orientation_row(model.principal, i),
            kin.vector(model.moments, i, 0), h, drift, estimated)
        kin.store(y, i, 0, x)
        kin.store(y, i, 3, q)
        kin.store(y, i, 10, big_l)
        if estimated:
            drifted = (estimate[i, 6], estimate[i, 7], estimate[i, 8], estimate[i, 9])
            kin.store(estimate, i, 6, kin.plus_scaled4(drifted, 1.0, error[1]))
            kin.store(estimate, i, 10, kin.add(kin.vector(estimate, i, 10), error[0]))


# Slots of a substep's estimate terms, per body, in the kernel that kicks and drifts all
# bodies in turn: position (0:3) and angle (3:6) from the kicks, the DLM drift's quaternion
# (6:10) and angular momentum (10:13).
@helper
def _add_kick_error(y, model, estimate, h, force, torque, before):
    """Add every body's :func:`_kick_error` of a drift of ``h`` into ``estimate``.

    ``force`` and ``torque`` (N, 3) are the kick's first wrench after it; ``before`` (N, 6)
    the one before it, which they then replace.
    """
    for i in range(y.shape[0]):
        f, t = kin.vector(force, i, 0), kin.vector(torque, i, 0)
        if h != 0.0:
            position, angle = _kick_error(kin.orientation(y, i), model.inverse_mass[i],
                                          kin.entries(model.inertia_inv, i), h, f, t,
                                          kin.vector(before, i, 0), kin.vector(before, i, 3))
            kin.store(estimate, i, 0, kin.add(kin.vector(estimate, i, 0), position))
            kin.store(estimate, i, 3, kin.add(kin.vector(estimate, i, 3), angle))
        kin.store(before, i, 0, f)
        kin.store(before, i, 3, t)


@helper
def _kick(y, work, model, effects, time, h, velocity_dependent, a, b):
    """Momenta after ``h`` of the wrench at fixed x and q, in place."""
    start, slopes, force, torque = work[0], work[1], work[2], work[3]
    if not velocity_dependent:
        accumulate(effects, y, time, model, force, torque)
        for i in range(y.shape[0]):
            for k in range(3):
                y[i, 7 + k] += h * force[i, k]
                y[i, 10 + k] += h * torque[i, k]
        return
    n = y.shape[0]
    kin.copy_columns(start, 0, y, 7, 6)
    for stage in range(b.size):
        for i in range(n):
            for j in range(6):
                value = start[i, j]
                for s in range(stage):
                    if a[stage, s] != 0.0:
                        value += h * a[stage, s] * slopes[s, i, j]
                y[i, 7 + j] = value
        accumulate(effects, y, time, model, force, torque)
        for i in range(n):
            for k in range(3):
                slopes[stage, i, k] = force[i, k]
                slopes[stage, i, 3 + k] = torque[i, k]
    for i in range(n):
        for j in range(6):
            value = start[i, j]
            for s in range(b.size):
                value += h * b[s] * slopes[s, i, j]
            y[i, 7 + j] = value


# What a substep's estimate is, a flag of the kernel: the Strang step's own terms (above),
# the Richardson comparison of the step with two of half its length from the same start, or
# nothing (no one reads it).
STRANG_TERMS, RICHARDSON, NO_ESTIMATE = 0, 1, 2
# A method of order 4 errs by C h^5 in a step of h and by 2 C (h/2)^5 in two of h/2: the
# step's error is 16/15 of the difference between the two results.
RICHARDSON_FACTOR = 16.0 / 15.0


@helper
def _richardson_error(full, halves, scales):
    """Scaled size of a step's local error, from its difference to two half steps.

    ``full`` and ``halves`` are a body's state after each, (x, q, p, L) tuples with unit
    ``q``; ``scales`` its :func:`body_scales`.
    """
    return RICHARDSON_FACTOR * scaled_size(
        kin.plus_scaled(full[0], -1.0, halves[0]), kin.plus_scaled4(full[1], -1.0, halves[1]),
        kin.plus_scaled(full[2], -1.0, halves[2]), kin.plus_scaled(full[3], -1.0, halves[3]),
        scales)


@helper(inline='always')
def _strang_composition(y, work, model, effects, time, h, substeps, weights, velocity_dependent,
                        a, b, drift, estimate, error):
    """``substeps`` composed kick-drift-kick steps of ``h`` on ``y`` in place.

    Each substep is estimated as ``estimate`` says (STRANG_TERMS, RICHARDSON, NO_ESTIMATE).
    Returns the failure code and the largest of the estimates it writes into ``error``
    (N,); NaN, ``error`` untouched, for NO_ESTIMATE.
    """
    estimated = estimate != NO_ESTIMATE
    if estimated:
        store_scales(y, model, h * substeps, work[6])
    arguments = (work, model, effects, time, h, weights, velocity_dependent, a, b, drift,
                 estimate, error)
    return substeps_checked(_strang_substep, y, substeps, arguments, error, estimated)


@helper
def _strang_substep(y, k, work, model, effects, time, h, weights, velocity_dependent, a, b,
                    drift, estimate, error):
    """Substep ``k`` of :func:`_strang_composition`, its estimate added into ``error``.

    RICHARDSON takes the substep again from the same start as two steps of ``h / 2``, in
    ``work``'s scratch state, and only reads the difference: ``y`` gets the step of ``h``,
    the same bits as unestimated.
    """
    estimates, scales, origin, halves = work[5], work[6], work[7], work[8]
    t = time + k * h
    if estimate == RICHARDSON:
        kin.copy_columns(origin, 0, y, 0, y.shape[1])
    _strang_step(y, work, model, effects, t, h, weights, velocity_dependent, a, b, drift,
                 estimate == STRANG_TERMS)
    if estimate == STRANG_TERMS:
        for i in range(y.shape[0]):
            error[i] += _substep_error(
                kin.orientation(y, i), kin.vector(estimates, i, 0), kin.vector(estimates, i, 3),
                (kin.vector(estimates, i, 10),
                 (estimates[i, 6], estimates[i, 7], estimates[i, 8], estimates[i, 9])),
                kin.vector(scales, i, 0))
    elif estimate == RICHARDSON:
        kin.copy_columns(halves, 0, origin, 0, origin.shape[1])
        for half in range(2):
            _strang_step(halves, work, model, effects, t + half * (0.5 * h), 0.5 * h, weights,
                         velocity_dependent, a, b, drift, False)
        for i in range(y.shape[0]):
            error[i] += _richardson_error(kin.body_state(y, i), kin.body_state(halves, i),
                                          kin.vector(scales, i, 0))


@helper(inline='always')
def _strang_step(y, work, model, effects, t, h, weights, velocity_dependent, a, b, drift,
                 terms):
    """One composed kick-drift-kick step of ``h`` from time ``t`` on ``y`` in place.

    The half kicks that end one Strang step of the composition and start the next act at the
    same state and time, so they merge: k Strang steps (k weights) cost k + 1 kicks. The
    quaternions leave normalised. With ``terms`` every body's Strang estimate terms go into
    ``work[5]`` (slots as :func:`_add_kick_error` and :func:`_drift` use them).
    """
    slopes, force, torque, before, estimates = work[1], work[2], work[3], work[4], work[5]
    # A kick's first wrench, at the momenta before it: the one the estimate compares.
    first_force = slopes[0, :, 0:3] if velocity_dependent else force
    first_torque = slopes[0, :, 3:6] if velocity_dependent else torque
    if terms:
        estimates[:, :] = 0.0
    kick = 0.5 * weights[0]
    for j in range(weights.size + 1):
        _kick(y, work, model, effects, t, kick * h, velocity_dependent, a, b)
        if terms:
            _add_kick_error(y, model, estimates, weights[j - 1] * h if j > 0 else 0.0,
                            first_force, first_torque, before)
        if j == weights.size:
            break
        _drift(y, model, weights[j] * h, drift, estimates, terms)
        t += weights[j] * h
        following = weights[j + 1] if j + 1 < weights.size else 0.0
        kick = 0.5 * (weights[j] + following)
    for i in range(y.shape[0]):
        kin.store(y, i, 3, kin.normalize(kin.orientation(y, i)))


_NO_TERMS = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0)))


@helper(inline='always')
def _body_step(i, state, body, effects, model, t, h, weights, a, b, drift, terms):
    """One composed step of ``h`` from time ``t`` of body ``i`` at ``state`` (x, q, p, L).

    ``body`` holds its inverse mass, inverse inertia (9-tuple), principal turn and moments.
    The arithmetic of :func:`_strang_step` for this body, in registers. Returns the state
    after (``q`` normalised) and, with ``terms``, its Strang estimate terms: position and
    angle from the kicks, the DLM drift's ``L`` and ``q`` errors.
    """
    x, q, p, big_l = state
    inverse_mass, inertia_inv, principal, moments = body
    zero = (0.0, 0.0, 0.0)
    position, angle = zero, zero
    drift_error = (zero, (0.0, 0.0, 0.0, 0.0))
    force_before, torque_before = zero, zero
    # Kick j is by the mean of the fractions before and after it (none: 0).
    for j in range(weights.size + 1):
        before = weights[j - 1] if j > 0 else 0.0
        after = weights[j] if j < weights.size else 0.0
        step = 0.5 * (before + after) * h
        stage_p, stage_l = p, big_l
        start_p, start_l = p, big_l
        for stage in range(b.size):   # at fixed x, q and t
            force, torque = body_wrench(effects, i, x, q, stage_p, stage_l, t, model)
            if terms and stage == 0:
                if j > 0:
                    dx, dangle = _kick_error(q, inverse_mass, inertia_inv, before * h,
                                             force, torque, force_before, torque_before)
                    position, angle = kin.add(position, dx), kin.add(angle, dangle)
                force_before, torque_before = force, torque
            p = kin.plus_scaled(p, step * b[stage], force)
            big_l = kin.plus_scaled(big_l, step * b[stage], torque)
            if stage + 1 < b.size:
                stage_p = kin.plus_scaled(start_p, step * a[stage + 1], force)
                stage_l = kin.plus_scaled(start_l, step * a[stage + 1], torque)
        if j < weights.size:
            x, q, big_l, error_lq = _drift_body(x, q, p, big_l, inverse_mass, principal,
                                                moments, weights[j] * h, drift, terms)
            if terms:
                drift_error = (kin.add(drift_error[0], error_lq[0]),
                               kin.plus_scaled4(drift_error[1], 1.0, error_lq[1]))
            t += weights[j] * h
    return (x, kin.normalize(q), p, big_l), (position, angle, drift_error)


@helper(inline='always')
def _strang_per_body(y, first_body, end, model, effects, time, h, substeps, weights, a, b,
                     drift, estimate, error):
    """:func:`_strang_composition` for effects that each act on one body.

    Steps the bodies ``first_body`` to ``end - 1``: calls on disjoint ranges may run at once
    on several threads (:class:`~rigid_sim.core.dispatch.BodyThreads`).

    Each body goes through all its substeps, kicks and drifts in registers
    (:func:`_body_step`), with the arithmetic :func:`_strang_composition` does for it, so
    the two agree to the last bit, estimates included. A kick is the Runge-Kutta method
    whose stages each use only the slope before (``a`` its subdiagonal, ``b`` its weights):
    one stage of weight 1 when no effect depends on the momenta, which is then the single
    evaluation of the other kernel. The failure code is that of the earliest bad substep
    over the bodies (the first such body's sign), as there. A kick called per body with
    arrays took and dropped references to every array of ``model`` and ``effects``, so the
    wrench is inlined here (docs/performance.md, "A body at a time").
    """
    estimated = estimate != NO_ESTIMATE
    first, largest = 0, (0.0 if estimated else math.nan)
    for i in range(first_body, end):
        state = kin.body_state(y, i)
        body = (model.inverse_mass[i], kin.entries(model.inertia_inv, i),
                kin.orientation_row(model.principal, i), kin.vector(model.moments, i, 0))
        scales = body_scales(model, i, state[2], state[3], h * substeps)
        total = 0.0
        for k in range(substeps):
            t = time + k * h
            start, kept, terms = state, state, _NO_TERMS
            # Run 0 is the step kept; Richardson's runs 1 and 2 the halves from its start.
            # One call in a loop, not three: each inlines the whole step and its wrench.
            for run in range(3 if estimate == RICHARDSON else 1):
                state, terms = _body_step(i, start if run < 2 else state, body, effects, model,
                                          t + 0.5 * h if run == 2 else t,
                                          h if run == 0 else 0.5 * h, weights, a, b, drift,
                                          estimate == STRANG_TERMS)
                if run == 0:
                    kept = state
            if estimate == STRANG_TERMS:
                total += _substep_error(kept[1], terms[0], terms[1], terms[2], scales)
            elif estimate == RICHARDSON:
                total += _richardson_error(kept, state, scales)
            state = kept
            code = kin.check_body(state[0], state[1], state[2], state[3])
            if code != 0:
                first, total = kin.earlier_failure(first, code, k + 1), math.inf
                break
        kin.store_body(y, i, state[0], state[1], state[2], state[3])
        if estimated:
            error[i] = total
            largest = max(largest, total)
    return first, largest


# One kernel per drift, the choice a constant inside, so the per-body branch compiles away.
# The estimate is a flag given at run time: it branches once a substep, and around the
# kicks' estimate terms, beside wrench evaluations and drifts that cost far more.
@kernel
def exact_flow_splitting(y, work, model, effects, time, h, substeps, weights,
                         velocity_dependent, a, b, estimate, error):
    """:func:`_strang_composition` drifting with the exact free flow."""
    return _strang_composition(y, work, model, effects, time, h, substeps, weights,
                               velocity_dependent, a, b, EXACT_DRIFT, estimate, error)


@kernel
def dlm_splitting(y, work, model, effects, time, h, substeps, weights, velocity_dependent, a,
                  b, estimate, error):
    """:func:`_strang_composition` drifting with the DLM rotations."""
    return _strang_composition(y, work, model, effects, time, h, substeps, weights,
                               velocity_dependent, a, b, DLM_DRIFT, estimate, error)


@kernel
def exact_flow_splitting_per_body(y, work, model, effects, time, h, substeps, weights,
                                  velocity_dependent, a, b, estimate, error):
    """:func:`_strang_per_body` with the exact free flow (``work`` unused)."""
    return _strang_per_body(y, 0, y.shape[0], model, effects, time, h, substeps, weights, a, b,
                            EXACT_DRIFT, estimate, error)


@kernel
def dlm_splitting_per_body(y, work, model, effects, time, h, substeps, weights,
                           velocity_dependent, a, b, estimate, error):
    """:func:`_strang_per_body` drifting with the DLM rotations (``work`` unused)."""
    return _strang_per_body(y, 0, y.shape[0], model, effects, time, h, substeps, weights, a, b,
                            DLM_DRIFT, estimate, error)


# Kernels for a range of bodies (``work``: first, end), called on several at once: compiled
# without the interpreter lock, which costs a one-call kernel 40 ns.
@kernel(nogil=True)
def exact_flow_splitting_threaded(y, work, model, effects, time, h, substeps, weights,
                                  velocity_dependent, a, b, estimate, error):
    """:func:`exact_flow_splitting_per_body` on bodies ``work[0]`` to ``work[1] - 1``."""
    return _strang_per_body(y, work[0], work[1], model, effects, time, h, substeps, weights, a,
                            b, EXACT_DRIFT, estimate, error)


@kernel(nogil=True)
def dlm_splitting_threaded(y, work, model, effects, time, h, substeps, weights,
                           velocity_dependent, a, b, estimate, error):
    """:func:`dlm_splitting_per_body` on bodies ``work[0]`` to ``work[1] - 1``."""
    return _strang_per_body(y, work[0], work[1], model, effects, time, h, substeps, weights, a,
                            b, DLM_DRIFT, estimate, error)


# (drift, per body) -> kernel
KERNELS = {(EXACT_DRIFT, False): exact_flow_splitting, (DLM_DRIFT, False): dlm_splitting,
           (EXACT_DRIFT, True): exact_flow_splitting_per_body,
           (DLM_DRIFT, True): dlm_splitting_per_body}
THREADED = {EXACT_DRIFT: exact_flow_splitting_threaded, DLM_DRIFT: dlm_splitting_threaded}


class StrangSplitting(Integrator):
    """Kick-drift-kick with a free-rotation drift; subclasses choose the drift."""

    order = 2
    weights = (1.0,)   # sub-step fractions; the Yoshida variants use three
    kick_tableau = EXPLICIT_MIDPOINT  # for momentum-dependent kicks, of the method's order
    drift = DLM_DRIFT
    estimate_kind = STRANG_TERMS   # how a step is estimated when it is

    def __init__(self, system, tolerance=1e-6, estimates=True, per_body=None):
        super().__init__(system, tolerance, estimates)
        count = self.bodies.count
        self._weights = np.array(self.weights, dtype=float)
        self._velocity_dependent = bool(system.velocity_dependent)
        self._estimate = self.estimate_kind if self.estimates else NO_ESTIMATE
        a, b, _ = self.kick_tableau.arrays()
        kicks = len(self.weights) + 1
        # Richardson's estimate steps three times: once kept, twice at half the length.
        passes = 3 if self._estimate == RICHARDSON else 1
        self.evaluations_per_step = passes * kicks * (b.size if system.velocity_dependent
                                                      else 1)
        # Effects that each act on one body let a body go through a whole step in registers:
        # no passes over the state and no scratch arrays. ``per_body`` False forces the
        # other order (tests).
        if per_body is None:
            per_body = acts_per_body(system.effect_parameters())
        self._kick_tableau = (a, b)
        if per_body:
            chained_a, chained_b, _ = (self.kick_tableau.chained() if system.velocity_dependent
                                       else FORWARD_EULER.chained())
            self._kick_tableau = (chained_a, chained_b)
        # The start and the half steps' state of Richardson's estimate: empty without it.
        scratch = count if self._estimate == RICHARDSON else 0
        self._work = () if per_body else (
            np.empty((count, 6)), np.empty((b.size, count, 6)), self._force, self._torque,
            np.zeros((count, 6)), np.empty((count, 13)), np.empty((count, 3)),
            np.empty((scratch, 13)), np.empty((scratch, 13)))
        self._kernel = CompiledCall(KERNELS[self.drift, per_body])
        if per_body:
            self._kernel = across_threads(self._kernel, THREADED[self.drift], count, heavy=True)

    def _advance(self, y, time, h, substeps, effects, continuing):
        a, b = self._kick_tableau
        return self._kernel(y, self._work, self.bodies.model, effects, time, h, substeps,
                            self._weights, self._velocity_dependent, a, b, self._estimate,
                            self.error)


class DLM(StrangSplitting):
    """Dullweber-Leimkuhler-McLachlan splitting. Order 2; two wrench evaluations (four damped).

    Symplectic and time-reversible: ``|L|`` of a torque-free body is exact to round-off and
    its energy error stays bounded (no drift) at any step; accurate up to ``|omega| dt ~ 1``.
    """

    name = 'dlm'
    bound = safeguards.STRANG_ACCURACY_ALL
    estimate_order = 2


class YoshidaComposition:
    """Three Strang steps of weights w1, w0, w1 (Yoshida's triple jump): order 4.

    Estimated by Richardson: the step again as two of half its length from the same start,
    16/15 of the difference (RICHARDSON_FACTOR), an h^5 estimate of the h^5 error. The
    signed sum of the three sub-steps' Strang estimates was 0.36 to 2.8e5 times the true
    error, shrinking as h^3 to h^5 by the forces. The kept result is the step of ``h``, so a
    world that reads no estimate (``estimates`` False) moves the same bits at a third of the
    work (docs/accuracy.md, "Error estimates").
    """

    order = 4
    weights = (YOSHIDA_OUTER, YOSHIDA_INNER, YOSHIDA_OUTER)
    kick_tableau = CLASSICAL_RK4
    estimate_order = 4   # Richardson's difference of an h^5 error: h^5
    estimate_kind = RICHARDSON
    estimate_optional = True


class DLM4(YoshidaComposition, DLM):
    """DLM composed by the Yoshida triple jump. Order 4; four wrench evaluations (16 damped).

    Three times as many with its estimate (Richardson, :class:`YoshidaComposition`).

    Keeps DLM's exact ``|L|`` and bounded energy; one inner sub-step runs backwards.
    """

    name = 'dlm4'
    bound = safeguards.YOSHIDA_ACCURACY_ALL


class ExactSplit(StrangSplitting):
    """Torque kicks around the exact free rotation (Jacobi elliptic flow). Order 2.

    A body no effect torques moves exactly (to ~1e-11) at any step: the scene calls for
    no torque, so none is integrated. With torques the error is O(dt^2) per unit time and
    ``|L|`` changes only through the kicks.
    """

    name = 'exact_split'
    drift = EXACT_DRIFT
    estimate_omits = ('the exact free flow\'s round-off: up to 3.6e-11 a step on a thin rod '
                      '(I = 1e-4, 1, 1.0001) spun about its middle axis')
    bound = safeguards.STRANG_ACCURACY
    estimate_order = 2


class ExactSplit4(YoshidaComposition, ExactSplit):
    """The exact-flow splitting composed by the Yoshida triple jump. Order 4."""

    name = 'exact_split4'
    estimate_omits = ('the exact free flow\'s round-off, which the Richardson difference reads '
                      'as noise: on a thin rod (I = 1e-4, 1, 1.0001) spun about its middle '
                      'axis, true errors up to 3.6e-11 a step, estimates up to 6.1e-11')
    bound = safeguards.YOSHIDA_ACCURACY
