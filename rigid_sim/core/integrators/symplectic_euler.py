# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Semi-implicit (symplectic) Euler: kick the momenta, then drift with the new velocities."""
import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core import safeguards
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.dispatch import CompiledCall
from rigid_sim.core.effects.base import accumulate
from rigid_sim.core.error_estimate import quaternion_error, scaled_size, store_scales
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.substeps import substeps_checked


@helper
def _kick_drift(y, model, force, torque, h, before, estimate, estimated):
    """Momenta kicked by the wrench, then x and q drifted with the new velocities.

    The step's local errors that the wrench at its start gives are written into
    ``estimate`` (N, 6), position and angle: ``h^2/2 F / M`` (the drift moves with the
    momentum at the step's end, not its mean) and ``h^2/2 I^-1 (tau + omega x L)`` (the
    rotation uses the angular velocity of the new ``L`` and the old orientation, Euler's
    equations a mean one). The wrench is kept in ``before`` (N, 6). ``estimated`` False
    (a constant of the kernel): neither.
    """
    for i in range(y.shape[0]):
        q = kin.orientation(y, i)
        r = kin.matrix(q)
        inertia_inv = kin.entries(model.inertia_inv, i)
        if estimated:
            f, t = kin.vector(force, i, 0), kin.vector(torque, i, 0)
            big_l, half = kin.vector(y, i, 10), 0.5 * h * h
            spin = kin.angular_velocity(r, inertia_inv, big_l)
            kin.store(estimate, i, 0, kin.scaled(half * model.inverse_mass[i], f))
            gyroscopic = kin.add(t, kin.cross(spin, big_l))
            kin.store(estimate, i, 3, kin.angular_velocity(r, inertia_inv,
                                                           kin.scaled(half, gyroscopic)))
            kin.store(before, i, 0, f)
            kin.store(before, i, 3, t)
        for k in range(3):
            y[i, 7 + k] += h * force[i, k]
            y[i, 10 + k] += h * torque[i, k]
        omega = kin.angular_velocity(r, inertia_inv, kin.vector(y, i, 10))
        for k in range(3):
            y[i, k] += y[i, 7 + k] * (h * model.inverse_mass[i])
        turn = kin.exp_map((omega[0] * h, omega[1] * h, omega[2] * h))
        kin.store(y, i, 3, kin.normalize(kin.multiply(turn, q)))


@helper
def _add_errors(y, model, force, torque, h, before, estimate, scales, error):
    """Add each body's estimate, closed by the momenta's errors, into ``error``.

    The momenta err by ``h/2`` times the change of the wrench over the step.

    ``force`` and ``torque`` hold the wrench at the step's end, ``before`` at its start.
    """
    for i in range(y.shape[0]):
        turn = quaternion_error(kin.vector(estimate, i, 3), kin.orientation(y, i))
        dp = kin.plus_scaled(kin.vector(force, i, 0), -1.0, kin.vector(before, i, 0))
        dl = kin.plus_scaled(kin.vector(torque, i, 0), -1.0, kin.vector(before, i, 3))
        error[i] += scaled_size(kin.vector(estimate, i, 0), turn, kin.scaled(0.5 * h, dp),
                                kin.scaled(0.5 * h, dl), kin.vector(scales, i, 0))


@helper(inline='always')
def _semi_implicit_euler(y, work, model, effects, time, h, substeps, estimated, error,
                         continuing):
    """``substeps`` steps of ``h`` on ``y`` in place; the failure code and largest estimate.

    The wrench at a step's end is the next step's first (and, when ``continuing``, the one
    ``work`` holds from the last call), so the estimate's wrench costs no evaluation.
    ``estimated`` False estimates nothing: ``error`` is left as it is, the largest is NaN.
    """
    force, torque, before, estimate, scales = work
    if estimated:
        store_scales(y, model, h * substeps, scales)
    if not continuing:
        accumulate(effects, y, time, model, force, torque)
    return substeps_checked(_substep, y, substeps,
                            (work, model, effects, time, h, estimated, error), error, estimated)


@helper
def _substep(y, k, work, model, effects, time, h, estimated, error):
    """Substep ``k`` of :func:`semi_implicit_euler`; the wrench at its end, its estimate."""
    force, torque, before, estimate, scales = work
    _kick_drift(y, model, force, torque, h, before, estimate, estimated)
    accumulate(effects, y, time + (k + 1) * h, model, force, torque)
    if estimated:
        _add_errors(y, model, force, torque, h, before, estimate, scales, error)


# The flag a constant of each kernel, as in the Runge-Kutta kernels.
@kernel
def semi_implicit_euler(y, work, model, effects, time, h, substeps, error, continuing):
    """:func:`_semi_implicit_euler`, estimated."""
    return _semi_implicit_euler(y, work, model, effects, time, h, substeps, True, error,
                                continuing)


@kernel
def semi_implicit_euler_unestimated(y, work, model, effects, time, h, substeps, error,
                                    continuing):
    """:func:`_semi_implicit_euler` without the estimate (``World(estimates=False)``)."""
    return _semi_implicit_euler(y, work, model, effects, time, h, substeps, False, error,
                                continuing)


class SemiImplicitEuler(Integrator):
    """``P += F dt, L += tau dt``; then ``x += v dt`` and ``q <- exp(omega dt) q``. Order 1.

    The rotation is applied as an exact exponential, so ``q`` stays unit without help and
    a spring's energy stays bounded for ``omega dt < 2`` instead of growing as in ``euler``.
    ``omega`` uses the new ``L`` with the old orientation.
    """

    name = 'semi_implicit_euler'
    order = 1
    bound = safeguards.SYMPLECTIC_EULER_STABILITY
    estimate_order = 1
    estimate_optional = True

    def __init__(self, system, tolerance=1e-6, estimates=True):
        super().__init__(system, tolerance, estimates)
        count = self.bodies.count
        self._work = (self._force, self._torque, np.zeros((count, 6)), np.empty((count, 6)),
                      np.empty((count, 3)))
        self._kernel = CompiledCall(semi_implicit_euler if self.estimates
                                    else semi_implicit_euler_unestimated)

    def _advance(self, y, time, h, substeps, effects, continuing):
        return self._kernel(y, self._work, self.bodies.model, effects, time, h, substeps,
                            self.error, continuing)
