# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Uniform gravity: ``F = M g`` at the centre of mass, so it never torques a body."""
import numpy as np

from rigid_sim.core.state import POSITION


class Gravity:
    """Uniform gravitational acceleration acting on every body."""

    def __init__(self, bodies, acceleration):
        self.acceleration = np.asarray(acceleration, dtype=float).reshape(3)
        # (N, 3) N, precomputed; a view of (3, N) rows, the layout integrators accumulate in.
        self._weight = (self.acceleration[:, None] * bodies.mass).T
        self.torqued = np.zeros(bodies.count, dtype=bool)
        self.velocity_dependent = False

    def accumulate(self, snapshot, force, torque):
        force += self._weight

    def potential_energy(self, snapshot):
        """``-sum M g . x``, J, zero at the world origin."""
        return -float(np.sum(self._weight * snapshot.y[:, POSITION]))
