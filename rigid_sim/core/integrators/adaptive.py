# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Adaptive Dormand-Prince 5(4), driven through scipy's RK45 stepper.

The error of each internal step is held below ``tolerance`` relative to a per-component
scale built from each body's own size, mass and inertia, so a microgram body is held to the
same relative accuracy as a kilogram one (an absolute tolerance would swamp the first and
starve the second). The right-hand side is one compiled call.
"""
import numpy as np

from rigid_sim.core import safeguards
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.runge_kutta import (body_momentum_derivative, from_body_axes,
                                                    to_body_axes)
from rigid_sim.core.kinematics import check_substep
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, POSITION


class Dopri5(Integrator):
    """Dormand-Prince 5(4) with error control on body-axes momenta. Order 5.

    ``dt`` is only the interval to reach; internal steps are chosen by the error estimate
    and the last accepted step size carries over to the next call.
    """

    name = 'dopri5'
    order = 5
    adaptive = True
    bound = safeguards.UNBOUNDED   # its error control chooses the internal steps

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        # Imported here: scipy.integrate takes a third of a second, which every start of the
        # node paid before it was needed only by this method.
        from scipy.integrate import RK45
        self._stepper = RK45
        self._step_size = None
        bodies = self.bodies
        self._inertia_scale = np.trace(bodies.inertia_body, axis1=1, axis2=2)  # kg m^2
        self._length = np.sqrt(self._inertia_scale / bodies.mass)   # radius of gyration, m
        self._work = (np.empty((bodies.count, 13)), np.empty((bodies.count, 3)), self._force,
                      self._torque)

    def _scale(self, z, dt):
        """Return the per-component size (N, 13) of the body-axes state ``z``.

        Positions scale with each body's radius of gyration, quaternion components with 1,
        and momenta with their own size or, at rest, with the body moving its own size in
        one step ``dt`` (s).
        """
        momentum = np.linalg.norm(z[:, LINEAR_MOMENTUM], axis=1)
        angular = np.linalg.norm(z[:, ANGULAR_MOMENTUM], axis=1)
        # A body at rest still has a natural momentum: moving its own size in one step.
        scale = np.ones_like(z)
        scale[:, ANGULAR_MOMENTUM] = np.maximum(angular, self._inertia_scale / dt)[:, None]
        scale[:, POSITION] = self._length[:, None]
        scale[:, LINEAR_MOMENTUM] = np.maximum(momentum, self.bodies.mass * self._length
                                               / dt)[:, None]
        return scale

    def advance(self, y, time, dt, substeps):
        """As :meth:`Integrator.advance`; its evaluations are counted as they happen."""
        return self._advance(y, time, dt / substeps, substeps)

    def _advance(self, y, time, h, substeps):
        for k in range(substeps):
            with np.errstate(all='ignore'):   # a non-finite result is handled, not warned
                self._interval(y, time + k * h, h)
            code = check_substep(y)
            if code != 0:
                return code * (k + 1)
        return 0

    def _interval(self, y, time, dt):
        """``y`` advanced in place by ``dt`` with error-controlled internal steps."""
        z = np.empty_like(y)
        to_body_axes(y, z)
        shape, model = z.shape, self.bodies.model
        effects, slope_out = self.system.effect_parameters(), np.empty(shape)

        def slope(t, flat):
            self.evaluations += 1
            return body_momentum_derivative(flat.reshape(shape), self._work, model, effects, t,
                                            slope_out).ravel().copy()

        end = time + dt
        solver = self._stepper(slope, time, z.ravel().copy(), end, rtol=self.tolerance,
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
        from_body_axes(np.ascontiguousarray(solver.y.reshape(shape)), y)
