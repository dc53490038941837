# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Linear and angular damping as decay rates of the momenta.

``F = -c_lin P`` and ``tau = -c_ang L`` (rates in 1/s) make free momenta decay exactly as
``exp(-c t)`` whatever the mass, size or tumbling of a body, so one coefficient means the
same thing for a microgram part and a crane load, and the decay has a closed form to test.
"""
import numpy as np

from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM


class Damping:
    """Momentum damping with rates ``linear`` and ``angular`` in 1/s."""

    def __init__(self, bodies, linear=0.0, angular=0.0):
        self.linear = float(linear)
        self.angular = float(angular)
        self.torqued = np.full(bodies.count, self.angular != 0.0)
        self.velocity_dependent = True

    def accumulate(self, snapshot, force, torque):
        force -= self.linear * snapshot.y[:, LINEAR_MOMENTUM]
        torque -= self.angular * snapshot.y[:, ANGULAR_MOMENTUM]

    def potential_energy(self, snapshot):
        return 0.0
