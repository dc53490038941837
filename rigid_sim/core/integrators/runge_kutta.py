# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Explicit Runge-Kutta methods with fixed steps, given as Butcher tableaux.

A method is data: its tableau and the momenta it differentiates. Baraff's world-axes ``L``
has ``omega = R I_body^-1 R^T L`` depend on ``q``, so every error in ``q`` feeds back into
``omega`` and grows. Body-axes ``L_b = R^T L`` has ``omega_b = I_body^-1 L_b`` independent
of ``q`` (Euler's equations): near the intermediate axis RK4 is 1000-2500x more accurate at
the same step in body axes (docs/accuracy.md). The public state stays Baraff's; only the
inside of a step changes: in body axes, slots 10:13 of the internal state hold ``L_b``.
"""
from dataclasses import dataclass

import numpy as np
from numba import njit

from rigid_sim.core import kinematics as kin
from rigid_sim.core import safeguards
from rigid_sim.core.effects.base import accumulate
from rigid_sim.core.integrators.base import Integrator


@dataclass(frozen=True)
class Tableau:
    """Butcher tableau of an explicit method: stage ``i`` uses ``a[i]`` of earlier slopes."""

    a: tuple   # lower-triangular rows, row i has i entries
    b: tuple   # weights
    c: tuple   # stage times as fractions of dt

    def arrays(self):
        """``a`` (S, S), ``b`` (S,), ``c`` (S,) as float arrays for the compiled kernel."""
        stages = len(self.b)
        a = np.zeros((stages, stages))
        for stage, row in enumerate(self.a):
            a[stage, :len(row)] = row
        return a, np.array(self.b, dtype=float), np.array(self.c, dtype=float)


FORWARD_EULER = Tableau(a=((),), b=(1.0,), c=(0.0,))
EXPLICIT_MIDPOINT = Tableau(a=((), (0.5,)), b=(0.0, 1.0), c=(0.0, 0.5))
CLASSICAL_RK4 = Tableau(
    a=((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0)),
    b=(1 / 6, 1 / 3, 1 / 3, 1 / 6),
    c=(0.0, 0.5, 0.5, 1.0),
)


@njit(cache=True)
def _to_internal(y, start, body_axes):
    """``start`` = ``y``, with ``L_b = R^T L`` in slots 10:13 when ``body_axes``."""
    start[:, :] = y
    if body_axes:
        for i in range(y.shape[0]):
            r = kin.matrix(kin.orientation(y, i))
            kin.store(start, i, 10, kin.rotate_inverse(r, kin.vector(y, i, 10)))


@njit(cache=True)
def _stage_state(start, slopes, a_row, h, inner, world, body_axes):
    """Stage ``inner`` = start + h sum a_row slopes, and its world-axes form ``world``."""
    n = start.shape[0]
    for i in range(n):
        for j in range(13):
            value = start[i, j]
            for s in range(a_row.size):
                if a_row[s] != 0.0:
                    value += h * a_row[s] * slopes[s, i, j]
            inner[i, j] = value
            world[i, j] = value
        if body_axes:
            r = kin.matrix(kin.orientation(inner, i))
            kin.store(world, i, 10, kin.rotate(r, kin.vector(inner, i, 10)))


@njit(cache=True)
def _slope(inner, model, force, torque, body_axes, out):
    """``d/dt`` of the internal state ``inner`` given the net wrench, into ``out`` (N, 13)."""
    for i in range(inner.shape[0]):
        q = kin.orientation(inner, i)
        r = kin.matrix(q)
        momentum = kin.vector(inner, i, 10)
        if body_axes:
            omega_body = kin.apply(model.inertia_inv[i], momentum)
            dq = kin.multiply(q, (omega_body[0], omega_body[1], omega_body[2], 0.0))
            turned = kin.rotate_inverse(r, kin.vector(torque, i, 0))
            gyroscopic = kin.cross(momentum, omega_body)   # L_b x omega_b = -omega_b x L_b
            dl = (turned[0] + gyroscopic[0], turned[1] + gyroscopic[1],
                  turned[2] + gyroscopic[2])
        else:
            omega = kin.angular_velocity(r, model.inertia_inv[i], momentum)
            dq = kin.multiply((omega[0], omega[1], omega[2], 0.0), q)
            dl = kin.vector(torque, i, 0)
        for k in range(3):
            out[i, k] = inner[i, 7 + k] * model.inverse_mass[i]
            out[i, 7 + k] = force[i, k]
            out[i, 10 + k] = dl[k]
        for k in range(4):
            out[i, 3 + k] = 0.5 * dq[k]


@njit(cache=True)
def body_momentum_derivative(inner, world, model, effects, time, force, torque, out):
    """``d/dt`` (N, 13) of the body-axes internal state ``inner`` at ``time``, into ``out``;
    ``world`` (N, 13) is scratch for its world-axes form, which the effects read."""
    for i in range(inner.shape[0]):
        for j in range(10):
            world[i, j] = inner[i, j]
        r = kin.matrix(kin.orientation(inner, i))
        kin.store(world, i, 10, kin.rotate(r, kin.vector(inner, i, 10)))
    accumulate(effects, world, time, model, force, torque)
    _slope(inner, model, force, torque, True, out)
    return out


@njit(cache=True)
def to_body_axes(y, start):
    """``start`` (N, 13) = ``y`` with ``L_b = R^T L`` in slots 10:13."""
    _to_internal(y, start, True)


@njit(cache=True)
def from_body_axes(start, y):
    """``y`` (N, 13) = ``start`` with a unit quaternion and world ``L`` from ``L_b``."""
    _to_public(start, np.zeros((0, start.shape[0], 13)), np.zeros(0), 0.0, y, True)


@njit(cache=True)
def _to_public(start, slopes, b, h, y, body_axes):
    """``y`` = start + h sum b slopes, with a unit quaternion and world-axes ``L``."""
    for i in range(y.shape[0]):
        for j in range(13):
            value = start[i, j]
            for s in range(b.size):
                value += h * b[s] * slopes[s, i, j]
            y[i, j] = value
        q = kin.normalize(kin.orientation(y, i))
        kin.store(y, i, 3, q)
        if body_axes:
            kin.store(y, i, 10, kin.rotate(kin.matrix(q), kin.vector(y, i, 10)))


@njit(cache=True)
def explicit_runge_kutta(y, work, model, effects, time, h, substeps, a, b, c, body_axes):
    """``substeps`` steps of ``h`` of the tableau (a, b, c) on ``y`` in place; failure code."""
    start, inner, world, slopes, force, torque = work
    for k in range(substeps):
        t = time + k * h
        _to_internal(y, start, body_axes)
        for stage in range(b.size):
            _stage_state(start, slopes, a[stage, :stage], h, inner, world, body_axes)
            accumulate(effects, world, t + c[stage] * h, model, force, torque)
            _slope(inner, model, force, torque, body_axes, slopes[stage])
        _to_public(start, slopes, b, h, y, body_axes)
        code = kin.check_substep(y)
        if code != 0:
            return code * (k + 1)
    return 0


class ExplicitRungeKutta(Integrator):
    """Integrate with the stages of ``tableau`` on world (``body_axes`` False) or body momenta.
    """

    tableau = None
    body_axes = False

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        self._tableau = self.tableau.arrays()
        self.evaluations_per_step = len(self.tableau.b)
        count = self.bodies.count
        self._work = (np.empty((count, 13)), np.empty((count, 13)), np.empty((count, 13)),
                      np.empty((len(self.tableau.b), count, 13)), self._force, self._torque)

    def _advance(self, y, time, h, substeps):
        a, b, c = self._tableau
        return explicit_runge_kutta(y, self._work, self.bodies.model,
                                    self.system.effect_parameters(), time, h, substeps, a, b,
                                    c, self.body_axes)


class ExplicitEuler(ExplicitRungeKutta):
    """Forward Euler on Baraff's ``dy/dt``. Order 1.

    Gains energy every step (a free body spirals out to its minor axis); kept as the
    baseline that Baraff's notes start from, not for use. Unstable at every step
    (``|1 + i w h| > 1``): substeps would only slow the growth, so it has no bound.
    """

    name = 'euler'
    order = 1
    tableau = FORWARD_EULER


class RK4World(ExplicitRungeKutta):
    """Classical RK4 on Baraff's world-axes ``L``. Order 4.

    Orientation error feeds back into omega: 1000-2500x less accurate than ``rk4`` near the
    intermediate axis at the same step. Kept to show that cost.
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
