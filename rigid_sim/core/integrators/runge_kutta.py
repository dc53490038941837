# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Explicit Runge-Kutta methods with fixed steps, given as Butcher tableaux.

A method is data: its tableau and the momenta it differentiates, in world or body axes
(:mod:`~rigid_sim.core.integrators.internal_state`: ``rk4`` against ``rk4_world`` in the
tumbling table of docs/accuracy.md, made by ``rigid_sim_bench accuracy``).
"""
import math
from dataclasses import dataclass

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core import safeguards
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.dispatch import across_threads, CompiledCall
from rigid_sim.core.effects.base import accumulate, acts_per_body, body_wrench
from rigid_sim.core.error_estimate import (body_scales, scaled_size, store_scales,
                                           turning_part)
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.internal_state import (add_slope, derivative, set_stage,
                                                       slope_of, to_internal, to_public)
from rigid_sim.core.integrators.substeps import substeps_checked
from rigid_sim.core.lanes import LANES_MIN


@dataclass(frozen=True)
class Tableau:
    """Butcher tableau of an explicit method: stage ``i`` uses ``a[i]`` of earlier slopes.

    Its error estimate is the difference to an embedded method of one order less that also
    uses the slope at the step's end (first same as last: that slope is the next step's
    first, so the estimate costs no evaluation): ``h (sum_i e_i k_i + e_end k_end)``, with
    ``e = b - b_embedded``. That is the embedded method's error, larger than the method's own
    by about one over ``z = h rho``, ``rho`` the local rate of the motion, which the first two
    stages measure (``|k2 - k1| / |Y2 - Y1|``, as Hairer and Wanner's stiffness detection
    does): a method with ``rate_weight`` reports the difference times ``rate_weight z``.
    """

    a: tuple          # lower-triangular rows, row i has i entries
    b: tuple          # weights
    c: tuple          # stage times as fractions of dt
    e: tuple          # weights of the stages' slopes in the error estimate
    e_end: float      # weight of the slope at the step's end in it
    rate_weight: float = 0.0   # the error over the difference per unit z (0: none)

    def arrays(self):
        """Return the tableau as float arrays ``a`` (S, S), ``b`` (S,), ``c`` (S,) (kicks)."""
        stages = len(self.b)
        a = np.zeros((stages, stages))
        for stage, row in enumerate(self.a):
            a[stage, :len(row)] = row
        return a, np.array(self.b, dtype=float), np.array(self.c, dtype=float)

    def chained(self):
        """Return ``a`` as its subdiagonal (S,), with ``b`` (S,) and ``c`` (S,).

        For tableaux whose stages each use only the slope before (forward Euler, classical
        RK4), which then need no stored slopes; ValueError for any other.
        """
        a, b, c = self.arrays()
        if np.any(np.tril(a, -2)):
            raise ValueError('a stage uses a slope other than the one before it')
        return np.concatenate(([0.0], np.diag(a, -1))), b, c

    def method(self):
        """Return what the kernels read: ``chained()``, ``e`` (S,), ``e_end``, ``rate_weight``."""
        return (*self.chained(), np.array(self.e, dtype=float), float(self.e_end),
                float(self.rate_weight))


# Embedded in forward Euler: Heun's trapezoid, (k1 + k_end) / 2. Euler's own local error is
# h^2/2 y'' = h/2 (k_end - k1) + O(h^3): the estimate is Euler's error itself.
FORWARD_EULER = Tableau(a=((),), b=(1.0,), c=(0.0,), e=(0.5,), e_end=-0.5)
# Used only as a splitting's kick, whose error the splitting estimates.
EXPLICIT_MIDPOINT = Tableau(a=((), (0.5,)), b=(0.0, 1.0), c=(0.0, 0.5), e=(0.0, 0.0),
                            e_end=0.0)
# Embedded in RK4: (k1 + 2 k2 + 2 k3 + k_end) / 6, third order (its four order conditions
# hold with k_end at c = 1 whose row is RK4's weights). On y' = lambda y the difference
# h/6 (k4 - k_end) is z^4/72 y and RK4's own error z^5/120 y: their ratio is 0.6 z. The
# first two stages see the rate of the first derivatives; near a separatrix the higher
# ones that make RK4's error run faster, and at 0.6 z the estimate fell to 1/17 of the true
# error on a tumbling body (rigid_sim_bench estimates, acc_tumbling): 2.5 times that, 1.5 z.
CLASSICAL_RK4 = Tableau(
    a=((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0)),
    b=(1 / 6, 1 / 3, 1 / 3, 1 / 6),
    c=(0.0, 0.5, 0.5, 1.0),
    e=(0.0, 0.0, 0.0, 1 / 6), e_end=-1 / 6, rate_weight=2.5 * 72 / 120,
)


@helper
def _runge_kutta_step(y, work, model, effects, time, h, method, body_axes, estimated, fsal):
    """One step of ``h`` on ``y`` in place; the estimate's terms of the stages into ``work``.

    Every stage uses only the slope of the one before, so no slope is stored: each body's
    slope goes straight into the sum and into the next stage. The first slope is the one
    ``fsal`` holds (the last step's end, or :func:`_start_slopes`). ``estimated`` False:
    no estimate's terms.
    """
    start, world, momentum, force, torque, estimate, scales, rates = work
    a, b, c, e, _, _ = method
    over_a21 = 1.0 / a[1] if b.size > 1 else 0.0   # for the rate: once, not for every body
    to_internal(y, start, body_axes)
    kin.copy_columns(world, 0, y, 0, 13)
    kin.copy_columns(momentum, 0, start, 10, 3)
    kin.copy_columns(y, 10, momentum, 0, 3)   # y now sums the step in the internal layout
    if estimated:
        estimate[:, :] = 0.0
    for stage in range(b.size):
        if stage > 0:
            accumulate(effects, world, time + c[stage] * h, model, force, torque)
        following = a[stage + 1] * h if stage + 1 < b.size else 0.0
        for i in range(y.shape[0]):
            slope = (kin.body_state(fsal, i) if stage == 0
                     else slope_of(world, momentum, model, force, torque, body_axes, i))
            add_slope(y, i, h * b[stage], slope)
            if estimated and e[stage] != 0.0:
                add_slope(estimate, i, h * e[stage], slope)
            if estimated and stage == 1:
                rates[i] = _step_rate(kin.body_state(fsal, i), slope, over_a21)
                if not body_axes:
                    rates[i] = max(rates[i], feedback_rate(model, i, kin.vector(start, i, 10), h))
            if stage + 1 < b.size:
                set_stage(start, i, following, slope, world, momentum, body_axes)
    to_public(y, body_axes)


@helper
def _start_slopes(y, work, model, effects, time, body_axes, fsal):
    """Every body's slope at the state ``y`` into ``fsal`` (N, 13), internal layout."""
    start, world, momentum, force, torque = work[0], work[1], work[2], work[3], work[4]
    to_internal(y, start, body_axes)
    kin.copy_columns(world, 0, y, 0, 13)
    kin.copy_columns(momentum, 0, start, 10, 3)
    accumulate(effects, world, time, model, force, torque)
    for i in range(y.shape[0]):
        kin.store_body(fsal, i, *slope_of(world, momentum, model, force, torque, body_axes, i))


@helper
def _end_slopes(y, work, model, effects, time, weight, rate_weight, body_axes, fsal, error):
    """Slopes at the end state ``y`` into ``fsal``; their estimate term closes ``error``.

    Body ``i``'s estimate of the step, the terms of ``work``'s estimate plus ``weight``
    times its end slope, in scaled units (times ``rate_weight`` and its rate, see
    :class:`Tableau`), is added to ``error[i]``.
    """
    estimate, scales, rates = work[5], work[6], work[7]
    _start_slopes(y, work, model, effects, time, body_axes, fsal)
    for i in range(y.shape[0]):
        slope = kin.body_state(fsal, i)
        add_slope(estimate, i, weight, slope)
        dx, dq, dp, dl = kin.body_state(estimate, i)
        error[i] += _own_error(scaled_size(dx, turning_part(dq, kin.orientation(y, i)), dp, dl,
                                           kin.vector(scales, i, 0)), rate_weight, rates[i])


@helper
def _squares(v):
    """Sum of the squares of a tuple's components."""
    total = 0.0
    for k in range(len(v)):
        total += v[k] * v[k]
    return total


@helper
def _squared_ratio(change, slope):
    """``|change|^2 / |slope|^2`` of two tuples (0 when both are 0, inf when only the slope is)."""
    moved = _squares(change)
    if moved == 0.0:
        return 0.0
    size = _squares(slope)
    return moved / size if size > 0.0 else math.inf


# Inlined: a call from the per-body kernel spilled every register its stages hold around
# it (13-20 ns of rk4's 170-190 at 1e4 bodies; docs/performance.md, "The rate's call").
@helper(inline='always')
def _step_rate(first, second, over_a21):
    """``z = h rho`` from a step's first two slopes ``k1``, ``k2`` (slope tuples).

    ``Y2 - Y1 = a21 h k1``, so ``|k2 - k1| / (a21 |k1|)`` is ``h rho`` (``over_a21`` is
    ``1 / a21``: a product, where a quotient cost every body a division), taken apart for each
    part of the state (so free of units). Translation: the position's and the momentum's
    ratios multiply to ``z^2`` for an oscillator of any amplitude and phase (each alone
    depends on both), so their geometric mean (the one that changes, when the other keeps
    still). Rotation: the quaternion turns at ``|omega|`` whatever the phase, and the
    angular momentum at its own rate; the larger. The larger of translation and rotation.
    Squared ratios throughout: two square roots in all.
    """
    translation, turn, angular = squared_part_rates(first, second)
    rate = math.sqrt(max(translation, max(turn, angular))) * over_a21
    return rate if math.isfinite(rate) else 0.0


@helper(inline='always')
def squared_part_rates(first, second):
    """``(h rho a21)^2`` of translation, quaternion and angular momentum (:func:`_step_rate`).

    From a step's first two slopes ``k1``, ``k2`` (slope tuples): ``|k2 - k1|^2 / |k1|^2`` of
    each part, the translation's the geometric mean of the position's and the momentum's
    (the one that changes, when the other keeps still).
    """
    change = _plus_slope(second, -1.0, first)
    position = _squared_ratio(change[0], first[0])
    momentum = _squared_ratio(change[2], first[2])
    if position > 0.0 and momentum > 0.0:
        translation = math.sqrt(position * momentum)
    else:
        translation = max(position, momentum)
    return (translation, _squared_ratio(change[1], first[1]),
            _squared_ratio(change[3], first[3]))


@helper
def feedback_rate(model, i, big_l, h):
    """``h |L| / I_min`` of body ``i``: the rate at which world-axes ``L`` feeds back.

    With world ``L`` the state, ``omega = R I^-1 R^T L``: an orientation error ``d theta``
    makes ``d omega = d theta x omega - R I^-1 R^T (d theta x L)``, up to ``2 |L| / I_min``
    times it, which turns the orientation further. The first two stages measure the rate
    only along the motion; this one is the feedback's across it (a thin rod, I_min = 1e-4,
    reaches 1e6 / s where it spins at 100 rad/s).
    """
    return h * math.sqrt(kin.dot(big_l, big_l)) / model.moments[i, 0]


@helper
def _own_error(difference, rate_weight, rate):
    """Return the method's own error from the embedded difference (:class:`Tableau`).

    Never above the difference: that bounds it, and a rate not measured (0) keeps it.
    """
    if rate_weight == 0.0 or rate == 0.0:
        return difference
    return difference * min(1.0, rate_weight * rate)


@helper(inline='always')
def _runge_kutta(y, work, model, effects, time, h, substeps, method, body_axes, estimated,
                 error, fsal, continuing):
    """``substeps`` steps of ``h`` of ``method`` on ``y`` in place; (failure code, largest).

    ``method`` is what :meth:`Tableau.method` returns; ``error`` (N,) receives each body's
    estimate summed over the substeps, ``fsal`` (N, 13) the slopes at the end. A slope
    (dx, dq, dP, dL) has the state's layout, so it is read and written as a body's state
    (``kin.body_state``, ``kin.store_body``). ``estimated`` False (a constant of the kernel)
    estimates nothing: ``error`` is left as it is and the largest is NaN.
    """
    if estimated:
        store_scales(y, model, h * substeps, work[6])
    if not continuing:
        _start_slopes(y, work, model, effects, time, body_axes, fsal)
    return substeps_checked(_runge_kutta_substep, y, substeps,
                            (work, model, effects, time, h, method, body_axes, estimated, error,
                             fsal), error, estimated)


@helper
def _runge_kutta_substep(y, k, work, model, effects, time, h, method, body_axes, estimated,
                         error, fsal):
    """Substep ``k`` of :func:`_runge_kutta`: a step of ``h`` from ``time + k h``, estimated."""
    _runge_kutta_step(y, work, model, effects, time + k * h, h, method, body_axes, estimated,
                      fsal)
    if estimated:
        _end_slopes(y, work, model, effects, time + (k + 1) * h, h * method[4], method[5],
                    body_axes, fsal, error)
    else:
        _start_slopes(y, work, model, effects, time + (k + 1) * h, body_axes, fsal)


@helper(inline='always')
def _runge_kutta_per_body(y, first_body, end, model, effects, time, h, substeps, method,
                          body_axes, estimated, error, fsal, continuing):
    """:func:`_runge_kutta` for effects that each act on one body: a body at a time.

    Steps the bodies ``first_body`` to ``end - 1``: calls on disjoint ranges may run at once
    on several threads (:class:`~rigid_sim.core.dispatch.BodyThreads`).

    Each body goes through all its substeps and stages in registers, with the arithmetic
    :func:`_runge_kutta` does for it, so the two agree to the last bit. Returns the failure
    code of the earliest bad substep over the bodies (the first such body's sign), as
    :func:`_runge_kutta` does. One function on purpose: a call per body, even inlined, took
    and dropped references to every array of ``model`` and ``effects`` (docs/performance.md,
    "A body at a time"). ``estimated`` False, as in :func:`_runge_kutta`.
    """
    a, b, c, e, e_end, rate_weight = method
    over_a21 = 1.0 / a[1] if b.size > 1 else 0.0   # for the rate: once, not for every body
    if not continuing:
        _start_slopes_per_body(y, first_body, end, model, effects, time, body_axes, fsal)
    first, largest = 0, (0.0 if estimated else math.nan)
    for i in range(first_body, end):
        x, q, p, big_l = kin.body_state(y, i)
        inertia_inv, inverse_mass = kin.entries(model.inertia_inv, i), model.inverse_mass[i]
        scales = (body_scales(model, i, p, big_l, h * substeps) if estimated
                  else (1.0, 1.0, 1.0))
        slope = kin.body_state(fsal, i)   # the first slope: the last step's end
        angular = kin.rotate_inverse(kin.matrix(q), big_l) if body_axes else big_l
        total = 0.0
        for k in range(substeps):
            start, rate = (x, q, p, angular), 0.0
            (x, q, p, angular), estimate = _take_slope(start, _NO_SLOPE, slope, h * b[0],
                                                       h * e[0] if estimated else 0.0)
            # Stages 1 .. S-1, then the end: one place evaluates the wrench, which numba
            # inlines (two inlined copies in one function confuse its variable scopes).
            for stage in range(1, b.size + 1):
                if stage < b.size:
                    step = a[stage] * h
                    stage_x = kin.plus_scaled(start[0], step, slope[0])
                    stage_q = kin.plus_scaled4(start[1], step, slope[1])
                    stage_p = kin.plus_scaled(start[2], step, slope[2])
                    stage_angular = kin.plus_scaled(start[3], step, slope[3])
                    stage_l = (kin.rotate(kin.matrix(stage_q), stage_angular) if body_axes
                               else stage_angular)
                    at = time + k * h + c[stage] * h
                else:   # the end, as the next substep starts from it
                    q = kin.normalize(q)
                    r = kin.matrix(q)
                    big_l = kin.rotate(r, angular) if body_axes else angular
                    stage_x, stage_q, stage_p, stage_l = x, q, p, big_l
                    stage_angular = kin.rotate_inverse(r, big_l) if body_axes else big_l
                    at = time + (k + 1) * h
                force, torque = body_wrench(effects, i, stage_x, stage_q, stage_p, stage_l, at,
                                            model)
                # The first slope, for the rate, kept only until the second is made: it takes
                # no registers through the other stages.
                previous = slope
                slope = derivative(stage_q, stage_p, stage_angular, force, torque,
                                   inertia_inv, inverse_mass, body_axes)
                if estimated and stage == 1 and stage < b.size:
                    rate = _step_rate(previous, slope, over_a21)
                    if not body_axes:
                        rate = max(rate, feedback_rate(model, i, start[3], h))
                if stage < b.size:
                    (x, q, p, angular), estimate = _take_slope(
                        (x, q, p, angular), estimate, slope, h * b[stage],
                        h * e[stage] if estimated else 0.0)
            angular = stage_angular   # the end's internal momentum, where the next starts
            if estimated:
                dx, dq, dp, dl = _plus_slope(estimate, h * e_end, slope)
                total += _own_error(scaled_size(dx, turning_part(dq, q), dp, dl, scales),
                                    rate_weight, rate)
            code = kin.check_body(x, q, p, big_l)
            if code != 0:
                first, total = kin.earlier_failure(first, code, k + 1), math.inf
                break
        kin.store_body(y, i, x, q, p, big_l)
        kin.store_body(fsal, i, *slope)
        if estimated:
            error[i] = total
            largest = max(largest, total)
    return first, largest


@helper
def _start_slopes_per_body(y, first_body, end, model, effects, time, body_axes, fsal):
    """:func:`_start_slopes` of bodies ``first_body`` to ``end - 1``, a body at a time."""
    for i in range(first_body, end):
        x, q, p, big_l = kin.body_state(y, i)
        angular = kin.rotate_inverse(kin.matrix(q), big_l) if body_axes else big_l
        force, torque = body_wrench(effects, i, x, q, p, big_l, time, model)
        slope = derivative(q, p, angular, force, torque, kin.entries(model.inertia_inv, i),
                           model.inverse_mass[i], body_axes)
        kin.store_body(fsal, i, *slope)


@helper
def _take_slope(sums, estimate, slope, weight, estimate_weight):
    """Return the step's sums and estimate (slope tuples) with ``slope`` added, weighted."""
    if estimate_weight != 0.0:   # most of a tableau's stages are not in its estimate
        estimate = _plus_slope(estimate, estimate_weight, slope)
    return _plus_slope(sums, weight, slope), estimate


_NO_SLOPE = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


@helper
def _plus_slope(u, weight, v):
    """Slope tuples ``u + weight v``."""
    return (kin.plus_scaled(u[0], weight, v[0]), kin.plus_scaled4(u[1], weight, v[1]),
            kin.plus_scaled(u[2], weight, v[2]), kin.plus_scaled(u[3], weight, v[3]))


# One kernel per formulation and per estimate, the flags constants inside: compiled in, the
# per-body branches on them disappear, which runtime flags keep in every body's loop. The
# kernels without an estimate serve worlds that neither control the error nor read it
# (``World(estimates=False)``).


@kernel
def body_axes_runge_kutta(y, work, model, effects, time, h, substeps, method, error, fsal,
                          continuing):
    """:func:`_runge_kutta` on body-axes angular momentum."""
    return _runge_kutta(y, work, model, effects, time, h, substeps, method, True, True, error,
                        fsal, continuing)


@kernel
def world_axes_runge_kutta(y, work, model, effects, time, h, substeps, method, error, fsal,
                           continuing):
    """:func:`_runge_kutta` on world-axes angular momentum."""
    return _runge_kutta(y, work, model, effects, time, h, substeps, method, False, True, error,
                        fsal, continuing)


@kernel
def body_axes_runge_kutta_unestimated(y, work, model, effects, time, h, substeps, method, error,
                                      fsal, continuing):
    """:func:`_runge_kutta` on body-axes angular momentum, no estimate."""
    return _runge_kutta(y, work, model, effects, time, h, substeps, method, True, False, error,
                        fsal, continuing)


@kernel
def world_axes_runge_kutta_unestimated(y, work, model, effects, time, h, substeps, method, error,
                                       fsal, continuing):
    """:func:`_runge_kutta` on world-axes angular momentum, no estimate."""
    return _runge_kutta(y, work, model, effects, time, h, substeps, method, False, False, error,
                        fsal, continuing)


@kernel
def body_axes_runge_kutta_per_body(y, work, model, effects, time, h, substeps, method, error, fsal,
                                   continuing):
    """:func:`_runge_kutta_per_body` on body-axes angular momentum."""
    return _runge_kutta_per_body(y, 0, y.shape[0], model, effects, time, h, substeps, method, True,
                                 True, error, fsal, continuing)


@kernel
def world_axes_runge_kutta_per_body(y, work, model, effects, time, h, substeps, method, error,
                                    fsal, continuing):
    """:func:`_runge_kutta_per_body` on world-axes angular momentum."""
    return _runge_kutta_per_body(y, 0, y.shape[0], model, effects, time, h, substeps, method,
                                 False, True, error, fsal, continuing)


@kernel
def body_axes_runge_kutta_per_body_unestimated(y, work, model, effects, time, h, substeps, method,
                                               error, fsal, continuing):
    """:func:`_runge_kutta_per_body` on body-axes angular momentum, no estimate."""
    return _runge_kutta_per_body(y, 0, y.shape[0], model, effects, time, h, substeps, method, True,
                                 False, error, fsal, continuing)


@kernel
def world_axes_runge_kutta_per_body_unestimated(y, work, model, effects, time, h, substeps, method,
                                                error, fsal, continuing):
    """:func:`_runge_kutta_per_body` on world-axes angular momentum, no estimate."""
    return _runge_kutta_per_body(y, 0, y.shape[0], model, effects, time, h, substeps, method,
                                 False, False, error, fsal, continuing)

# Kernels for a range of bodies (``work``: first, end), called on several at once: compiled
# without the interpreter lock, which costs a one-call kernel 40 ns.


@kernel(nogil=True)
def body_axes_runge_kutta_threaded(y, work, model, effects, time, h, substeps, method, error, fsal,
                                   continuing):
    """:func:`body_axes_runge_kutta_per_body` on bodies ``work[0]`` to ``work[1] - 1``."""
    return _runge_kutta_per_body(y, work[0], work[1], model, effects, time, h, substeps, method,
                                 True, True, error, fsal, continuing)


@kernel(nogil=True)
def world_axes_runge_kutta_threaded(y, work, model, effects, time, h, substeps, method, error,
                                    fsal, continuing):
    """:func:`world_axes_runge_kutta_per_body` on bodies ``work[0]`` to ``work[1] - 1``."""
    return _runge_kutta_per_body(y, work[0], work[1], model, effects, time, h, substeps, method,
                                 False, True, error, fsal, continuing)


@kernel(nogil=True)
def body_axes_runge_kutta_threaded_unestimated(y, work, model, effects, time, h, substeps, method,
                                               error, fsal, continuing):
    """:func:`body_axes_runge_kutta_per_body_unestimated` on ``work[0]`` to ``work[1] - 1``."""
    return _runge_kutta_per_body(y, work[0], work[1], model, effects, time, h, substeps, method,
                                 True, False, error, fsal, continuing)


@kernel(nogil=True)
def world_axes_runge_kutta_threaded_unestimated(y, work, model, effects, time, h, substeps, method,
                                                error, fsal, continuing):
    """:func:`world_axes_runge_kutta_per_body_unestimated` on ``work[0]`` to ``work[1] - 1``."""
    return _runge_kutta_per_body(y, work[0], work[1], model, effects, time, h, substeps, method,
                                 False, False, error, fsal, continuing)


# (body axes, per body, estimated) -> kernel; (body axes, estimated) -> kernel for a range
KERNELS = {(True, False, True): body_axes_runge_kutta,
           (False, False, True): world_axes_runge_kutta,
           (True, True, True): body_axes_runge_kutta_per_body,
           (False, True, True): world_axes_runge_kutta_per_body,
           (True, False, False): body_axes_runge_kutta_unestimated,
           (False, False, False): world_axes_runge_kutta_unestimated,
           (True, True, False): body_axes_runge_kutta_per_body_unestimated,
           (False, True, False): world_axes_runge_kutta_per_body_unestimated}
THREADED = {(True, True): body_axes_runge_kutta_threaded,
            (False, True): world_axes_runge_kutta_threaded,
            (True, False): body_axes_runge_kutta_threaded_unestimated,
            (False, False): world_axes_runge_kutta_threaded_unestimated}


def lanes_kernel(estimated):
    """Return the kernel that steps bodies in lanes (``rk4``: body-axes momenta).

    Its module is imported here, by the first integrator that uses it: it builds on this
    one, and a process that never steps :data:`~rigid_sim.core.lanes.LANES_MIN` bodies
    never imports it.
    """
    from rigid_sim.core.integrators import rk4_lanes
    return rk4_lanes.KERNELS[estimated]


class ExplicitRungeKutta(Integrator):
    """Integrate with the stages of ``tableau`` on world (``body_axes`` False) or body momenta.

    The tableau's stages each use only the slope before (see :meth:`Tableau.chained`).
    ``per_body`` and ``in_lanes`` (None: chosen by the effects and the body count) force
    the kernel's loop order, for tests: a body at a time, or blocks of bodies in lanes.
    """

    tableau = None
    body_axes = False
    estimate_optional = True

    def __init__(self, system, tolerance=1e-6, estimates=True, per_body=None, in_lanes=None):
        super().__init__(system, tolerance, estimates)
        self._method = self.tableau.method()
        self.evaluations_per_step = len(self.tableau.b)
        count = self.bodies.count
        # Effects that each act on one body let a body go through all stages in registers:
        # one pass over the state instead of several per stage (all of it, at large N), and
        # no scratch arrays to pass. ``per_body`` False forces the other order (tests).
        if per_body is None:
            per_body = acts_per_body(system.effect_parameters())
        self._work = () if per_body else (
            np.empty((count, 13)), np.empty((count, 13)), np.empty((count, 3)), self._force,
            self._torque, np.empty((count, 13)), np.empty((count, 3)), np.zeros(count))
        self._end_slopes = np.zeros((count, 13))   # first same as last: the next step's first
        # Many bodies on body-axes momenta (rk4): blocks of them in lanes, the same bits.
        # ``in_lanes`` True or False forces the choice (tests).
        if in_lanes is None:
            in_lanes = per_body and self.body_axes and count >= LANES_MIN
        if in_lanes and not (per_body and self.body_axes):
            raise ValueError(f'{self.name} cannot step these bodies in lanes: the kernel in '
                             'lanes is for body-axes momenta (rk4) and effects that each act '
                             'on one body')
        if not per_body:
            self._kernel = CompiledCall(KERNELS[self.body_axes, False, self.estimates])
        elif in_lanes:
            self._work = (0, count)   # the kernel's range of bodies: all of them
            kernel = lanes_kernel(self.estimates)
            self._kernel = across_threads(CompiledCall(kernel), kernel, count)
        else:
            self._kernel = across_threads(
                CompiledCall(KERNELS[self.body_axes, True, self.estimates]),
                THREADED[self.body_axes, self.estimates], count)

    def _advance(self, y, time, h, substeps, effects, continuing):
        return self._kernel(y, self._work, self.bodies.model, effects, time, h, substeps,
                            self._method, self.error, self._end_slopes, continuing)


class ExplicitEuler(ExplicitRungeKutta):
    """Forward Euler on Baraff's ``dy/dt``. Order 1.

    Gains energy every step (a free body spirals out to its minor axis); kept as the
    baseline that Baraff's notes start from, not for use. Unstable at every step
    (``|1 + i w h| > 1``): substeps would only slow the growth, so it has no bound.
    """

    name = 'euler'
    order = 1
    tableau = FORWARD_EULER
    bound = safeguards.UNBOUNDED
    estimate_order = 1


class RK4World(ExplicitRungeKutta):
    """Classical RK4 on Baraff's world-axes ``L``. Order 4.

    Orientation error feeds back into omega, so near the intermediate axis it is far less
    accurate than ``rk4`` at the same step (docs/accuracy.md, tumbling table). Kept as the
    textbook formulation, to show that cost.
    """

    name = 'rk4_world'
    order = 4
    tableau = CLASSICAL_RK4
    bound = safeguards.RK4_STABILITY
    # Its error feeds back through q into omega, faster than the stages' rate shows (on a
    # thin rod 35 times the stages' rate-scaled estimate): the rate is at least that of the
    # feedback (:func:`feedback_rate`).
    estimate_order = 4   # the embedded difference times z: h^5


class RK4(ExplicitRungeKutta):
    """Classical RK4 on body-axes angular momentum. Order 4, four wrench evaluations.

    Not symplectic: energy drifts as O(dt^4) per unit time; stable for spring
    ``omega dt < 2.83`` and, for rotation, up to ``|omega| dt`` of about 2.8.
    """

    name = 'rk4'
    order = 4
    tableau = CLASSICAL_RK4
    body_axes = True
    bound = safeguards.RK4_STABILITY
    estimate_order = 4   # the embedded difference times z: h^5
