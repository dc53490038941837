# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Linear and angular damping as decay rates of the momenta.

``F = -c_lin P`` and ``tau = -c_ang L`` (rates in 1/s) make free momenta decay exactly as
``exp(-c t)`` whatever the mass, size or tumbling of a body, so one coefficient means the
same thing for a microgram part and a crane load, and the decay has a closed form to test.
"""
from typing import NamedTuple

import numpy as np

from rigid_sim.core.effects.base import Effect, body_kernel_for
from rigid_sim.core.compiled import helper
from rigid_sim.core.scene_fields import non_negative, table


class DampingParameters(NamedTuple):
    """What the compiled kernel reads."""

    linear: float    # 1/s
    angular: float   # 1/s


class Damping(Effect):
    """Momentum damping with rates ``linear`` and ``angular`` in 1/s."""

    name = 'damping'
    scene_fields = table({'linear': (non_negative, 0.0), 'angular': (non_negative, 0.0)})
    parts = (DampingParameters,)
    velocity_dependent = True

    def __init__(self, bodies, linear=0.0, angular=0.0):
        super().__init__(bodies)
        self.linear = float(linear)
        self.angular = float(angular)
        self.torqued = np.full(bodies.count, self.angular != 0.0)

    @property
    def parameters(self):
        """Return the :class:`DampingParameters` the compiled kernel reads."""
        return DampingParameters(self.linear, self.angular)

    def fastest_rate(self):
        """Return the faster of the two decay rates, 1/s."""
        return max(self.linear, self.angular)


@body_kernel_for(DampingParameters)
@helper
def damping_wrench(parameters, i, x, q, p, big_l, time, model):
    """``-c_lin P`` and ``-c_ang L`` of one body."""
    linear, angular = parameters.linear, parameters.angular
    return (-linear * p[0], -linear * p[1], -linear * p[2]), \
        (-angular * big_l[0], -angular * big_l[1], -angular * big_l[2])
