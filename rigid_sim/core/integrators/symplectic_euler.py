# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Semi-implicit (symplectic) Euler: kick the momenta, then drift with the new velocities."""
import numpy as np

from rigid_sim.core import rotation
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, ORIENTATION, POSITION

MOMENTA = slice(LINEAR_MOMENTUM.start, ANGULAR_MOMENTUM.stop)   # rows of [P, L], as [F, tau]


class SemiImplicitEuler(Integrator):
    """``P += F dt, L += tau dt``; then ``x += v dt`` and ``q <- exp(omega dt) q``. Order 1.

    The rotation is applied as an exact exponential, so ``q`` stays unit without help and
    a spring's energy stays bounded for ``omega dt < 2`` instead of growing as in ``euler``.
    ``omega`` uses the new ``L`` with the old orientation.
    """

    name = 'semi_implicit_euler'
    order = 1

    def _step_impl(self, rows, time, dt):
        bodies, rows = self.bodies, np.array(rows, order='C')
        matrices = rotation.matrix_rows(rows[ORIENTATION])
        self.wrench_rows(rows, time, matrices)
        rows[MOMENTA] += dt * self._wrench
        body_l = rotation.rotate_inverse_rows(matrices, rows[ANGULAR_MOMENTUM])
        body_omega = rotation.rotate_rows(bodies.inertia_body_inv_rows, body_l)
        omega = rotation.rotate_rows(matrices, body_omega)
        rows[POSITION] += rows[LINEAR_MOMENTUM] * (dt * bodies.inverse_mass)
        omega *= dt
        rows[ORIENTATION] = rotation.multiply_rows(rotation.exp_map_rows(omega),
                                                   rows[ORIENTATION])
        return rows
