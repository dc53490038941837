# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Adaptive Dormand-Prince 5(4), driven through scipy's RK45 stepper.

The error of each internal step is measured relative to a per-component scale built from
each body's own size, mass and inertia, so a microgram body is held to the same relative
accuracy as a kilogram one (an absolute tolerance would swamp the first and starve the
second). The right-hand side is one compiled call. The error estimate of every internal step
(the difference of the embedded fourth-order solution, which scipy's stepper computes to
control the step) is the fourth-order solution's error, while the fifth-order one is kept:
on ``y' = lambda y`` the difference is ``97 z^5 / 120000`` and the kept solution's error
``-z^6 / 3600 + z^7 / 5040`` (``z = h lambda``; from scipy's tableau), so the kept error is
``100 / 291 z`` times the difference. A spin turns the quaternion with ``lambda = i w / 2``:
there the ``z^6`` term only changes its length, which the step's normalisation takes away,
and the turn that is left, ``(1/5040 + 1/3600) |z|^7``, is ``0.589 |z|^2`` times the
difference. As for ``rk4`` (:class:`~rigid_sim.core.integrators.runge_kutta.Tableau`), the
rates are what the first two stages measure, per body (:func:`_part_rates`): the estimate is
the difference times ``min(1, 100 z / 291 + 0.589 s^2)``, ``z`` the rate of the position,
momentum and body-axes angular momentum, ``s`` the quaternion's. It is reported per body in
the units of :mod:`rigid_sim.core.error_estimate`, summed over the internal steps of a call.

That sum is what a step reports, so it is what is held to ``tolerance``: each internal step
of length ``h`` in a step of ``dt`` must keep its estimate, the largest over the components
(the reported unit, not scipy's root mean square), below ``tolerance h / dt`` (error per
unit step). The accepted internal steps then sum to at most ``tolerance``. Held per internal
step to ``tolerance`` in scipy's norm instead, the thin rod of the estimate cases reported
3e-6 against 1e-6 on every step of 0.01 s, unflagged.

A tolerance far below what a motion allows (1e-12 on a fast-spinning rod) asks for millions
of internal steps per call, seconds to minutes in one call that no executor round can
interrupt. The internal steps of one call are capped (:data:`MAX_INTERNAL_STEPS`, fewer for
a large world: :data:`INTERNAL_WORK` body-steps): past the cap the call gives up with
:class:`StepsCapped`, the state kept, and says so.
"""
import math

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core import safeguards
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.effects.base import accumulate
from rigid_sim.core.error_estimate import state_scales
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.internal_state import (add_slope, set_stage, slope_of,
                                                       to_internal, to_public)
from rigid_sim.core.integrators.runge_kutta import squared_part_rates
from rigid_sim.core.kinematics import check_substep

# Internal steps one call may take at most: scipy's stepper costs 0.2 ms a step for a few
# bodies on this machine idle, 0.8 ms under a load of 10 (docs/performance.md, control
# latency: 200 steps answered control in 160 ms there), so one call stays within about
# 40 ms. The tests' tightest use (1e-10 over 0.05 s on one body) takes fewer.
MAX_INTERNAL_STEPS = 50
# Body-steps (internal steps times bodies) one call may take at most: the same bound where
# the compiled right-hand side, not the stepper, is most of the cost.
INTERNAL_WORK = 10_000
# The kept fifth-order solution's error over the embedded difference, per unit z = h lambda,
# and for a spin per unit s^2 (module docstring; scipy's RK45 tableau on y' = lambda y).
RATE_WEIGHT = 100.0 / 291.0
SPIN_WEIGHT = (1.0 / 5040.0 + 1.0 / 3600.0) / (97.0 / 120000.0)


def per_unit_step(stepper):
    """Return scipy's ``stepper`` class with the error test this module holds a step to.

    Its step is accepted when its estimate (:func:`own_errors`, the largest over the bodies)
    is below ``per_second |h|``, the scaled error a step may make per second; ``scale``
    (N, 13) and ``per_second`` are set on the instance before its first step, and
    ``body_error`` (N,) holds the estimate of the step last tried, the one kept once ``step``
    returns. Only the norm is replaced (scipy's ``_estimate_error_norm``, the method its
    step-size control calls); scipy still chooses, rejects and grows the steps.
    """
    # A private method (unchanged since scipy 1.0): should it change, the estimates' test of
    # dopri5 on the thin rod finds steps kept above their tolerance.
    class PerUnitStep(stepper):
        scale = None        # (N, 13) each component's scale (rigid_sim.core.error_estimate)
        per_second = None   # scaled error a step may make per second of it
        body_error = None   # (N,) the last step's estimate, scaled

        def _estimate_error_norm(self, K, h, scale):
            self.body_error = own_errors(self._estimate_error(K, h), K, self.scale,
                                         1.0 / self.A[1, 0])
            return self.body_error.max() / self.per_second / abs(h)

    return PerUnitStep


def own_errors(difference, stages, scale, over_a21):
    """(N,) scaled error of the kept solution of one step, from the embedded ``difference``.

    ``difference`` (N * 13,) is the pair's difference, ``stages`` the step's slopes (S, N * 13),
    ``scale`` (N, 13). Each body's largest scaled component of the difference, times
    ``min(1, RATE_WEIGHT z + SPIN_WEIGHT s^2)`` with its rates (:func:`_part_rates`); none
    measured (both 0) or not finite: the difference itself, which bounds the error.
    """
    shape = scale.shape
    return _own_errors(difference.reshape(shape), stages[0].reshape(shape),
                       stages[1].reshape(shape), scale, over_a21, np.empty(shape[0]))


@kernel
def _own_errors(difference, first, second, scale, over_a21, out):
    """:func:`own_errors` on (N, 13) arrays, into ``out`` (N,)."""
    for i in range(scale.shape[0]):
        size = 0.0
        for k in range(13):
            size = max(size, abs(difference[i, k]) / scale[i, k])
        z, s = _part_rates(first, second, i, over_a21)
        factor = RATE_WEIGHT * z + SPIN_WEIGHT * s * s
        out[i] = size * (min(1.0, factor) if 0.0 < factor < math.inf else 1.0)
    return out


@helper
def _part_rates(first, second, i, over_a21):
    """Rates ``z`` and ``s`` of body ``i``'s step from its first two slopes (N, 13 each).

    ``Y2 - Y1 = a21 h k1``, so ``|k2 - k1| / (a21 |k1|)`` is ``h`` times the local rate
    (Hairer and Wanner's stiffness detection), taken apart for each part of the state by
    :func:`~rigid_sim.core.integrators.runge_kutta.squared_part_rates`: ``z`` the larger of
    the translation's (the geometric mean of the position's and the momentum's, which
    multiply to ``z^2`` for an oscillator of any phase) and the body-axes angular
    momentum's; ``s`` the quaternion's, ``h |omega| / 2`` whatever the phase.
    """
    translation, turn, angular = squared_part_rates(kin.body_state(first, i),
                                                    kin.body_state(second, i))
    return math.sqrt(max(translation, angular)) * over_a21, math.sqrt(turn) * over_a21


class StepsCapped(ArithmeticError):
    """A call of dopri5 would take more internal steps than its cap; the state is kept.

    The step controller gives the step up at once (more pieces would only take more steps).
    """


@kernel
def body_momentum_derivative(inner, work, model, effects, time, out):
    """Compute the time derivative of the body-axes internal state, for an external stepper.

    Parameters
    ----------
    inner : (N, 13) float
        Internal state [x, q, P, L_b]: x and P in the world frame, ``L_b`` in body axes.
    work : tuple of arrays
        Scratch: world state (N, 13), momentum (N, 3), force (N, 3), torque (N, 3).
    model : Model
        The bodies' static arrays.
    effects : tuple of NamedTuple
        The effects' parameters (see ``effects.base.accumulate``).
    time : float
        Simulated time, s.
    out : (N, 13) float
        Where ``d inner / dt`` is written.

    Returns
    -------
    (N, 13) float
        ``out``.
    """
    world, momentum, force, torque = work
    zero = (0.0, 0.0, 0.0)
    for i in range(inner.shape[0]):
        set_stage(inner, i, 0.0, (zero, (0.0, 0.0, 0.0, 0.0), zero, zero), world, momentum,
                  True)
    accumulate(effects, world, time, model, force, torque)
    for i in range(inner.shape[0]):
        for k in range(13):
            out[i, k] = 0.0
        add_slope(out, i, 1.0, slope_of(world, momentum, model, force, torque, True, i))
    return out


@kernel
def to_body_axes(y, start):
    """``start`` (N, 13) = ``y`` with ``L_b = R^T L`` in slots 10:13."""
    to_internal(y, start, True)


@kernel
def from_body_axes(start, y):
    """``y`` (N, 13) = ``start`` with a unit quaternion and world ``L`` from ``L_b``."""
    kin.copy_columns(y, 0, start, 0, 13)
    to_public(y, True)


class Dopri5(Integrator):
    """Dormand-Prince 5(4) with error control on body-axes momenta. Order 5.

    ``dt`` is only the interval to reach; internal steps are chosen by the error estimate
    and the last accepted step size carries over to the next call.
    """

    name = 'dopri5'
    order = 5
    adaptive = True
    bound = safeguards.UNBOUNDED   # its error control chooses the internal steps
    estimate_order = 5             # the embedded difference times z: h^6
    evaluations_per_step = 0       # counted as they happen

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        # Imported here: scipy.integrate takes a third of a second, which every start of the
        # node paid before it was needed only by this method.
        from scipy.integrate import RK45
        self._stepper = per_unit_step(RK45)
        self._step_size = None
        bodies = self.bodies
        self._work = (np.empty((bodies.count, 13)), np.empty((bodies.count, 3)), self._force,
                      self._torque)
        self.cap = max(1, min(MAX_INTERNAL_STEPS, INTERNAL_WORK // max(1, bodies.count)))
        self._left = self.cap   # internal steps the current call may still take

    def _advance(self, y, time, h, substeps, effects, continuing):
        self.error[:] = 0.0
        self._left = self.cap
        for k in range(substeps):
            with np.errstate(all='ignore'):   # a non-finite result is handled, not warned
                self._interval(y, time + k * h, h, effects, h * substeps)
            code = check_substep(y)
            if code != 0:
                return code * (k + 1), np.inf
        return 0, self.error.max()

    def _interval(self, y, time, dt, effects, span):
        """``y`` advanced in place by ``dt`` with error-controlled internal steps.

        ``span`` (s) is the whole step the estimates of its intervals add up over: each
        internal step of ``h`` may make ``tolerance h / span`` of it.
        """
        z = np.empty_like(y)
        to_body_axes(y, z)
        shape, model = z.shape, self.bodies.model
        slope_out = np.empty(shape)
        # Each body's own sizes (rigid_sim.core.error_estimate): a body at rest still has a
        # natural momentum, moving its own size in one step dt.
        scale = state_scales(model, z, dt, np.empty(shape))

        def slope(t, flat):
            self.evaluations += 1
            return body_momentum_derivative(flat.reshape(shape), self._work, model, effects, t,
                                            slope_out).ravel().copy()

        end = time + dt
        solver = self._stepper(slope, time, z.ravel().copy(), end, rtol=self.tolerance,
                               atol=self.tolerance * scale.ravel(),
                               first_step=min(self._step_size or dt, end - time))
        # The error test (rtol and atol above only feed scipy's own norm, which it replaces).
        solver.scale, solver.per_second = scale, self.tolerance / span
        while solver.status == 'running':
            if self._left == 0:
                self._step_size = solver.h_abs   # where the next call starts again
                raise StepsCapped(
                    f'dopri5 capped at {self.cap} internal steps in a step of {dt:.3g} s, '
                    f'{end - solver.t:.3g} s short of its end (tolerance {self.tolerance:.3g}, '
                    f'internal step {solver.h_abs:.3g} s): the step is given up; a larger '
                    'tolerance or time_step reaches it')
            self._left -= 1
            message = solver.step()
            if solver.status == 'failed':
                raise FloatingPointError(f'dopri5 failed: {message}')
            self.error += solver.body_error   # of the step kept
        # The step the error estimate proposes next, not the last one cut short by `end`.
        self._step_size = solver.h_abs
        from_body_axes(np.ascontiguousarray(solver.y.reshape(shape)), y)
