# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Explicit Runge-Kutta methods with fixed steps, given as Butcher tableaux.

A method is data: its tableau and the momenta it differentiates. Baraff's world-axes ``L``
has ``omega = R I_body^-1 R^T L`` depend on ``q``, so every error in ``q`` feeds back into
``omega`` and grows. Body-axes ``L_b = R^T L`` has ``omega_b = I_body^-1 L_b`` independent
of ``q`` (Euler's equations), so near the intermediate axis RK4 in body axes is orders of
magnitude more accurate at the same step (``rk4`` against ``rk4_world`` in the tumbling
table of docs/accuracy.md, made by ``rigid_sim_bench accuracy``). The public state stays
Baraff's; only the inside of a step changes: in body axes, slots 10:13 of the internal state
hold ``L_b``.
"""
from dataclasses import dataclass

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core import safeguards
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.dispatch import CompiledCall
from rigid_sim.core.effects.base import accumulate, acts_per_body, body_wrench
from rigid_sim.core.integrators.base import Integrator


@dataclass(frozen=True)
class Tableau:
    """Butcher tableau of an explicit method: stage ``i`` uses ``a[i]`` of earlier slopes."""

    a: tuple   # lower-triangular rows, row i has i entries
    b: tuple   # weights
    c: tuple   # stage times as fractions of dt

    def arrays(self):
        """Return ``a`` (S, S), ``b`` (S,), ``c`` (S,) as float arrays for the compiled kernel."""
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


FORWARD_EULER = Tableau(a=((),), b=(1.0,), c=(0.0,))
EXPLICIT_MIDPOINT = Tableau(a=((), (0.5,)), b=(0.0, 1.0), c=(0.0, 0.5))
CLASSICAL_RK4 = Tableau(
    a=((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0)),
    b=(1 / 6, 1 / 3, 1 / 3, 1 / 6),
    c=(0.0, 0.5, 0.5, 1.0),
)


@helper
def _to_internal(y, start, body_axes):
    """``start`` = ``y``, with ``L_b = R^T L`` in slots 10:13 when ``body_axes``."""
    kin.copy_columns(start, 0, y, 0, 13)
    if body_axes:
        for i in range(y.shape[0]):
            r = kin.matrix(kin.orientation(y, i))
            kin.store(start, i, 10, kin.rotate_inverse(r, kin.vector(y, i, 10)))


@helper
def _derivative(q, momentum, angular, force, torque, inertia_inv, inverse_mass, body_axes):
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
def _slope(world, momentum, model, force, torque, body_axes, i):
    """:func:`_derivative` of body ``i`` of a stage held in arrays.

    ``world`` (N, 13) holds the stage in world axes, ``momentum`` (N, 3) its internal
    angular momentum.
    """
    return _derivative(kin.orientation(world, i), kin.vector(world, i, 7),
                       kin.vector(momentum, i, 0), kin.vector(force, i, 0),
                       kin.vector(torque, i, 0), kin.entries(model.inertia_inv, i),
                       model.inverse_mass[i], body_axes)


@helper
def _set_stage(start, i, step, slope, world, momentum, body_axes):
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
def _add_slope(y, i, weight, slope):
    """``y[i] += weight slope`` in the internal layout."""
    dx, dq, dp, dl = slope
    for k in range(3):
        y[i, k] += weight * dx[k]
        y[i, 7 + k] += weight * dp[k]
        y[i, 10 + k] += weight * dl[k]
    for k in range(4):
        y[i, 3 + k] += weight * dq[k]


@helper
def _to_public(y, body_axes):
    """Normalise the quaternions and turn ``L_b`` (slots 10:13) into world-axes ``L``, in place."""
    for i in range(y.shape[0]):
        q = kin.normalize(kin.orientation(y, i))
        kin.store(y, i, 3, q)
        if body_axes:
            kin.store(y, i, 10, kin.rotate(kin.matrix(q), kin.vector(y, i, 10)))


@helper
def _runge_kutta_step(y, work, model, effects, time, h, a, b, c, body_axes):
    """One step of ``h`` on ``y`` in place.

    Every stage uses only the slope of the one before, so no slope is stored: each body's
    slope goes straight into the sum and into the next stage.
    """
    start, world, momentum, force, torque = work
    _to_internal(y, start, body_axes)
    kin.copy_columns(world, 0, y, 0, 13)
    kin.copy_columns(momentum, 0, start, 10, 3)
    kin.copy_columns(y, 10, momentum, 0, 3)   # y now sums the step in the internal layout
    for stage in range(b.size):
        accumulate(effects, world, time + c[stage] * h, model, force, torque)
        following = a[stage + 1] * h if stage + 1 < b.size else 0.0
        for i in range(y.shape[0]):
            slope = _slope(world, momentum, model, force, torque, body_axes, i)
            _add_slope(y, i, h * b[stage], slope)
            if stage + 1 < b.size:
                _set_stage(start, i, following, slope, world, momentum, body_axes)
    _to_public(y, body_axes)


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
        _set_stage(inner, i, 0.0, (zero, (0.0, 0.0, 0.0, 0.0), zero, zero), world, momentum,
                   True)
    accumulate(effects, world, time, model, force, torque)
    for i in range(inner.shape[0]):
        for k in range(13):
            out[i, k] = 0.0
        _add_slope(out, i, 1.0, _slope(world, momentum, model, force, torque, True, i))
    return out


@kernel
def to_body_axes(y, start):
    """``start`` (N, 13) = ``y`` with ``L_b = R^T L`` in slots 10:13."""
    _to_internal(y, start, True)


@kernel
def from_body_axes(start, y):
    """``y`` (N, 13) = ``start`` with a unit quaternion and world ``L`` from ``L_b``."""
    kin.copy_columns(y, 0, start, 0, 13)
    _to_public(y, True)


@helper(inline='always')
def _runge_kutta(y, work, model, effects, time, h, substeps, a, b, c, body_axes):
    """``substeps`` steps of ``h`` of the tableau (a, b, c) on ``y`` in place; failure code."""
    for k in range(substeps):
        _runge_kutta_step(y, work, model, effects, time + k * h, h, a, b, c, body_axes)
        code = kin.check_substep(y)
        if code != 0:
            return code * (k + 1)
    return 0


@helper(inline='always')
def _runge_kutta_per_body(y, model, effects, time, h, substeps, a, b, c, body_axes):
    """:func:`_runge_kutta` for effects that each act on one body: a body at a time.

    Each body goes through all its substeps and stages in registers, with the arithmetic
    :func:`_runge_kutta` does for it, so the two agree to the last bit. Returns the failure
    code of the earliest bad substep over the bodies (the first such body's sign), as
    :func:`_runge_kutta` does. One function on purpose: a call per body, even inlined, took
    and dropped references to every array of ``model`` and ``effects`` (docs/performance.md,
    "A body at a time").
    """
    first = 0
    for i in range(y.shape[0]):
        x, q, p, big_l = kin.body_state(y, i)
        inertia_inv, inverse_mass = kin.entries(model.inertia_inv, i), model.inverse_mass[i]
        for k in range(substeps):
            angular = kin.rotate_inverse(kin.matrix(q), big_l) if body_axes else big_l
            start = (x, q, p, angular)
            stage_x, stage_q, stage_p, stage_angular, stage_l = x, q, p, angular, big_l
            for stage in range(b.size):
                force, torque = body_wrench(effects, i, stage_x, stage_q, stage_p, stage_l,
                                            time + k * h + c[stage] * h, model)
                dx, dq, dp, dl = _derivative(stage_q, stage_p, stage_angular, force, torque,
                                             inertia_inv, inverse_mass, body_axes)
                weight = h * b[stage]
                x, q = kin.plus_scaled(x, weight, dx), kin.plus_scaled4(q, weight, dq)
                p = kin.plus_scaled(p, weight, dp)
                angular = kin.plus_scaled(angular, weight, dl)
                if stage + 1 < b.size:
                    step = a[stage + 1] * h
                    stage_x = kin.plus_scaled(start[0], step, dx)
                    stage_q = kin.plus_scaled4(start[1], step, dq)
                    stage_p = kin.plus_scaled(start[2], step, dp)
                    stage_angular = kin.plus_scaled(start[3], step, dl)
                    stage_l = (kin.rotate(kin.matrix(stage_q), stage_angular) if body_axes
                               else stage_angular)
            q = kin.normalize(q)
            big_l = kin.rotate(kin.matrix(q), angular) if body_axes else angular
            code = kin.check_body(x, q, p, big_l)
            if code != 0:
                first = kin.earlier_failure(first, code, k + 1)
                break
        kin.store_body(y, i, x, q, p, big_l)
    return first


# One kernel per formulation, the flag a constant inside: compiled in, the per-body branch
# on it disappears, which a runtime flag keeps in every body's loop.
@kernel
def body_axes_runge_kutta(y, work, model, effects, time, h, substeps, a, b, c):
    """:func:`_runge_kutta` on body-axes angular momentum."""
    return _runge_kutta(y, work, model, effects, time, h, substeps, a, b, c, True)


@kernel
def world_axes_runge_kutta(y, work, model, effects, time, h, substeps, a, b, c):
    """:func:`_runge_kutta` on Baraff's world-axes angular momentum."""
    return _runge_kutta(y, work, model, effects, time, h, substeps, a, b, c, False)


@kernel
def body_axes_runge_kutta_per_body(y, work, model, effects, time, h, substeps, a, b, c):
    """:func:`_runge_kutta_per_body` on body-axes angular momentum (``work`` unused)."""
    return _runge_kutta_per_body(y, model, effects, time, h, substeps, a, b, c, True)


@kernel
def world_axes_runge_kutta_per_body(y, work, model, effects, time, h, substeps, a, b, c):
    """:func:`_runge_kutta_per_body` on world-axes angular momentum (``work`` unused)."""
    return _runge_kutta_per_body(y, model, effects, time, h, substeps, a, b, c, False)


# (body axes, per body) -> kernel
_KERNELS = {(True, False): body_axes_runge_kutta, (False, False): world_axes_runge_kutta,
            (True, True): body_axes_runge_kutta_per_body,
            (False, True): world_axes_runge_kutta_per_body}


class ExplicitRungeKutta(Integrator):
    """Integrate with the stages of ``tableau`` on world (``body_axes`` False) or body momenta.

    The tableau's stages each use only the slope before (see :meth:`Tableau.chained`).
    """

    tableau = None
    body_axes = False

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        self._tableau = self.tableau.chained()
        self.evaluations_per_step = len(self.tableau.b)
        count = self.bodies.count
        # Effects that each act on one body let a body go through all stages in registers:
        # one pass over the state instead of several per stage (all of it, at large N), and
        # no scratch arrays to pass.
        per_body = acts_per_body(system.effect_parameters())
        self._work = () if per_body else (np.empty((count, 13)), np.empty((count, 13)),
                                          np.empty((count, 3)), self._force, self._torque)
        self._kernel = CompiledCall(_KERNELS[self.body_axes, per_body])

    def _advance(self, y, time, h, substeps):
        a, b, c = self._tableau
        return self._kernel(y, self._work, self.bodies.model, self.system.effect_parameters(),
                            time, h, substeps, a, b, c)


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
