# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Semi-implicit (symplectic) Euler: kick the momenta, then drift with the new velocities."""

from rigid_sim.core import kinematics as kin
from rigid_sim.core import safeguards
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.dispatch import CompiledCall
from rigid_sim.core.effects.base import accumulate
from rigid_sim.core.integrators.base import Integrator


@helper
def _kick_drift(y, model, force, torque, h):
    """Momenta kicked by the wrench, then x and q drifted with the new velocities."""
    for i in range(y.shape[0]):
        for k in range(3):
            y[i, 7 + k] += h * force[i, k]
            y[i, 10 + k] += h * torque[i, k]
        q = kin.orientation(y, i)
        r = kin.matrix(q)
        omega = kin.angular_velocity(r, kin.entries(model.inertia_inv, i),
                                     kin.vector(y, i, 10))
        for k in range(3):
            y[i, k] += y[i, 7 + k] * (h * model.inverse_mass[i])
        turn = kin.exp_map((omega[0] * h, omega[1] * h, omega[2] * h))
        kin.store(y, i, 3, kin.normalize(kin.multiply(turn, q)))


@kernel
def semi_implicit_euler(y, model, effects, time, h, substeps, force, torque):
    """``substeps`` steps of ``h`` on ``y`` in place; the failure code of ``advance``."""
    for k in range(substeps):
        accumulate(effects, y, time + k * h, model, force, torque)
        _kick_drift(y, model, force, torque, h)
        code = kin.check_substep(y)
        if code != 0:
            return code * (k + 1)
    return 0


class SemiImplicitEuler(Integrator):
    """``P += F dt, L += tau dt``; then ``x += v dt`` and ``q <- exp(omega dt) q``. Order 1.

    The rotation is applied as an exact exponential, so ``q`` stays unit without help and
    a spring's energy stays bounded for ``omega dt < 2`` instead of growing as in ``euler``.
    ``omega`` uses the new ``L`` with the old orientation.
    """

    name = 'semi_implicit_euler'
    order = 1
    bound = safeguards.SYMPLECTIC_EULER_STABILITY

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        self._kernel = CompiledCall(semi_implicit_euler)

    def _advance(self, y, time, h, substeps):
        return self._kernel(y, self.bodies.model, self.system.effect_parameters(), time, h,
                            substeps, self._force, self._torque)
