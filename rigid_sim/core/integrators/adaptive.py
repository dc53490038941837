# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Adaptive Dormand-Prince 5(4), driven through scipy's RK45 stepper.

The error of each internal step is held below ``tolerance`` relative to a per-component
scale built from each body's own size, mass and inertia, so a microgram body is held to the
same relative accuracy as a kilogram one (an absolute tolerance would swamp the first and
starve the second).
"""
import numpy as np
from scipy.integrate import RK45

from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.formulations import INNER_P, INNER_X, INNER_L, BodyMomentum


class Dopri5(Integrator):
    """Dormand-Prince 5(4) with error control on body-axes momenta. Order 5.

    ``dt`` is only the interval to reach; internal steps are chosen by the error estimate
    and the last accepted step size carries over to the next call.
    """

    name = 'dopri5'
    order = 5
    adaptive = True

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        self._step_size = None
        self._formulation = BodyMomentum(self)
        bodies = self.bodies
        self._inertia_scale = np.trace(bodies.inertia_body, axis1=1, axis2=2)  # kg m^2
        self._length = np.sqrt(self._inertia_scale / bodies.mass)   # radius of gyration, m

    def _scale(self, z, dt):
        """Per-component size (13, N) of internal rows ``[L_b, x, q, P]``.

        Lengths, 1 for q, momenta of the body's own scale.
        """
        momentum = np.linalg.norm(z[INNER_P], axis=0)
        angular = np.linalg.norm(z[INNER_L], axis=0)
        # A body at rest still has a natural momentum: moving its own size in one step.
        scale = np.ones_like(z)
        scale[INNER_L] = np.maximum(angular, self._inertia_scale / dt)
        scale[INNER_X] = self._length
        scale[INNER_P] = np.maximum(momentum, self.bodies.mass * self._length / dt)
        return scale

    def _step_impl(self, rows, time, dt):
        f = self._formulation
        z = f.to_internal(rows)
        shape = z.shape
        slope_rows = np.empty(shape)

        def slope(t, flat):
            f.state[...] = flat.reshape(shape)
            return f.slope(t, out=slope_rows).ravel().copy()

        end = time + dt
        solver = RK45(slope, time, z.ravel().copy(), end, rtol=self.tolerance,
                      atol=self.tolerance * self._scale(z, dt).ravel(),
                      first_step=min(self._step_size or dt, end - time))
        self.last_substeps = 0
        while solver.status == 'running':
            message = solver.step()
            self.last_substeps += 1
            if solver.status == 'failed':
                raise FloatingPointError(f'dopri5 failed: {message}')
        # The step the error estimate proposes next, not the last one cut short by `end`.
        self._step_size = solver.h_abs
        return f.to_public(solver.y.reshape(shape))
