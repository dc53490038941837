# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Explicit Runge-Kutta methods with fixed steps, given as Butcher tableaux.

A method is data: its tableau and the formulation it differentiates
(:mod:`rigid_sim.core.integrators.formulations`).
"""
from dataclasses import dataclass

import numpy as np

from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.formulations import BodyMomentum, WorldMomentum


@dataclass(frozen=True)
class Tableau:
    """Butcher tableau of an explicit method: stage ``i`` uses ``a[i]`` of earlier slopes."""

    a: tuple   # lower-triangular rows, row i has i entries
    b: tuple   # weights
    c: tuple   # stage times as fractions of dt


FORWARD_EULER = Tableau(a=((),), b=(1.0,), c=(0.0,))
EXPLICIT_MIDPOINT = Tableau(a=((), (0.5,)), b=(0.0, 1.0), c=(0.0, 0.5))
CLASSICAL_RK4 = Tableau(
    a=((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0)),
    b=(1 / 6, 1 / 3, 1 / 3, 1 / 6),
    c=(0.0, 0.5, 0.5, 1.0),
)


class ExplicitRungeKutta(Integrator):
    """Integrate ``formulation.slope`` with the stages of ``tableau``.

    Slopes live in one (stages, 13, N) array so that each stage's combination of earlier
    slopes is a single ``einsum`` call whatever the number of bodies.
    """

    tableau = None
    formulation = None

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        self._formulation = self.formulation(self)
        self._slopes = np.empty((len(self.tableau.b), 13, self.bodies.count))
        weights = np.zeros((len(self.tableau.b), len(self.tableau.b)))
        for stage, row in enumerate(self.tableau.a):
            weights[stage, :len(row)] = row
        # Per stage: the earlier slopes it uses and their weights, found once, not per step.
        used = [np.flatnonzero(weights[stage, :stage]) for stage in range(len(weights))]
        self._stages = [(fraction, used[stage], weights[stage, used[stage]])
                        for stage, fraction in enumerate(self.tableau.c)]
        self._b = np.asarray(self.tableau.b)

    def _step_impl(self, rows, time, dt):
        f, slopes = self._formulation, self._slopes
        z = f.to_internal(rows)
        for stage, (fraction, used, weights) in enumerate(self._stages):
            if used.size == 1:   # one earlier slope (every classical stage): no reduction
                np.multiply(slopes[used[0]], dt * weights[0], out=f.state)
                f.state += z
            elif used.size:
                np.einsum('s,sin->in', dt * weights, slopes[used], out=f.state)
                f.state += z
            else:
                f.state[...] = z
            f.slope(time + fraction * dt, out=slopes[stage])
        combined = np.einsum('s,sin->in', dt * self._b, slopes, out=f.state)
        combined += z
        return f.to_public(combined)


class ExplicitEuler(ExplicitRungeKutta):
    """Forward Euler on Baraff's ``dy/dt``. Order 1.

    Gains energy every step (a free body spirals out to its minor axis); kept as the
    baseline that Baraff's notes start from, not for use.
    """

    name = 'euler'
    order = 1
    tableau = FORWARD_EULER
    formulation = WorldMomentum


class RK4World(ExplicitRungeKutta):
    """Classical RK4 on Baraff's world-axes ``L``. Order 4.

    Orientation error feeds back into omega: 1000-2500x less accurate than ``rk4`` near the
    intermediate axis at the same step. Kept to show that cost.
    """

    name = 'rk4_world'
    order = 4
    tableau = CLASSICAL_RK4
    formulation = WorldMomentum


class RK4(ExplicitRungeKutta):
    """Classical RK4 on body-axes angular momentum. Order 4, four wrench evaluations.

    Not symplectic: energy drifts as O(dt^4) per unit time; stable for spring
    ``omega dt < 2.83`` and, for rotation, up to ``|omega| dt`` of about 2.8.
    """

    name = 'rk4'
    order = 4
    tableau = CLASSICAL_RK4
    formulation = BodyMomentum
