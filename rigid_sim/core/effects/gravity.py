# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Uniform gravity: ``F = M g`` at the centre of mass, so it never torques a body."""
from typing import NamedTuple

import numpy as np

from rigid_sim.core.effects.base import Effect, body_kernel_for
from rigid_sim.core.compiled import helper
from rigid_sim.core.scene_fields import REQUIRED, table, vector
from rigid_sim.core.state import POSITION


class GravityParameters(NamedTuple):
    """What the compiled kernel reads."""

    weight: np.ndarray   # (N, 3) N, ``M g`` of each body


class Gravity(Effect):
    """Uniform gravitational acceleration acting on every body."""

    name = 'gravity'
    scene_fields = table({'acceleration': (vector, REQUIRED)})   # m/s^2, world axes
    parts = (GravityParameters,)

    def __init__(self, bodies, acceleration):
        super().__init__(bodies)
        self.acceleration = np.asarray(acceleration, dtype=float).reshape(3)
        self._weight = np.ascontiguousarray(bodies.mass[:, None] * self.acceleration)

    @property
    def parameters(self):
        """Return the :class:`GravityParameters` the compiled kernel reads."""
        return GravityParameters(self._weight)

    def potential_energy(self, snapshot):
        """``-sum M g . x``, J, zero at the world origin."""
        return -float(np.sum(self._weight * snapshot.y[:, POSITION]))


@body_kernel_for(GravityParameters)
@helper
def gravity_wrench(parameters, i, x, q, p, big_l, time, model):
    """Body ``i``'s weight, at its centre of mass: no torque."""
    weight = parameters.weight
    return (weight[i, 0], weight[i, 1], weight[i, 2]), (0.0, 0.0, 0.0)


def gravity_of(effects):
    """Return the (3,) acceleration, m/s^2, of the :class:`Gravity` in ``effects``; None: none."""
    return next((effect.acceleration for effect in effects if isinstance(effect, Gravity)),
                None)
