# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The contract every integrator fulfils.

An integrator advances the packed Baraff state ``y`` (N, 13) = [x, q, P, L] of all bodies.
It is built for a *system* that provides ``bodies`` (the
:class:`~rigid_sim.core.state.RigidBodies`), ``effect_parameters()`` (the tuple of the
parameters of the scene's effects and of its inputs, which
:func:`rigid_sim.core.effects.base.accumulate` sums in compiled code) and
``velocity_dependent`` (whether any effect's wrench depends on the momenta). It reads them
once, to choose its compiled kernel, and keeps no reference to the system: every call of
:meth:`Integrator.advance` is given the effects' parameters of that moment.

Every call also estimates its local error per body (:mod:`rigid_sim.core.error_estimate`)
into ``error``; ``largest_error`` is their largest. Built with ``estimates`` False (nothing
controls the error or reads it), a method with ``estimate_optional`` (``rk4``,
``rk4_world``, ``euler``, ``semi_implicit_euler``, ``dlm4``, ``exact_split4``) runs kernels
without that work, and
``error`` and ``largest_error`` read NaN, not estimated; the others estimate anyway. A
method whose estimate per step shrinks as ``h^(estimate_order + 1)`` declares
``estimate_order``, from which the step controller predicts the substeps a tolerance needs.

To write a new method, subclass :class:`Integrator`, set ``name``, ``order``, ``bound``
(from :mod:`rigid_sim.core.safeguards`), ``estimate_order`` and ``evaluations_per_step``,
implement ``_advance`` with one compiled call, and add the class to the registry in
``integrators/__init__.py``. Quaternions leave every step unit.
"""
import numpy as np


class Integrator:
    """Base class: steps of ``h`` for every body at once, in place, in compiled code."""

    name = ''
    order = 0          # global order of accuracy
    adaptive = False   # True: ``tolerance`` controls the error, not ``dt``
    # What the estimate leaves out, in words ('' for nothing the tests found): the error it
    # does not see, measured (docs/accuracy.md, "Error estimates").
    estimate_omits = ''
    # bound: the largest step it takes unsplit, a safeguards.StepBound that every method
    # declares for itself (registration refuses one that does not).
    evaluations_per_step = 1       # wrench evaluations of one step
    estimate_optional = False      # has kernels without the error estimate
    # estimate_order: the local error estimate per step shrinks as h^(estimate_order + 1);
    # declared by every method (registration refuses one that does not).

    def __init__(self, system, tolerance=1e-6, estimates=True):
        self.bodies = system.bodies
        self.tolerance = float(tolerance)
        self.estimates = bool(estimates) or not self.estimate_optional
        self.evaluations = 0     # wrench evaluations since construction
        count = self.bodies.count
        # (N,) local error estimate of the last call, per body, and its largest
        self.error = np.zeros(count) if self.estimates else np.full(count, np.nan)
        self.largest_error = 0.0 if self.estimates else np.nan
        self._force = np.zeros((count, 3))
        self._torque = np.zeros((count, 3))

    def advance(self, y, time, dt, substeps, effects, continuing=False):
        """Advance ``y`` (N, 13, C-contiguous) in place by ``dt`` in ``substeps`` equal steps.

        ``effects`` are the effects' and inputs' parameters to sum. ``continuing`` says that
        ``y`` is exactly the state the last call of this integrator ended at and that the
        effects are unchanged since, so what that call computed at its end (the slope a
        first-same-as-last method starts from) still holds.

        Returns 0, or the failure code of the first bad substep ``k`` (1-based): ``k`` for a
        non-finite state, ``-k`` for a quaternion that overflowed before it was normalised
        (see :func:`rigid_sim.core.step_control.failure_message`). ``y`` is then garbage.
        Sets ``error`` and ``largest_error``, the sums over the substeps.
        """
        self.evaluations += self.evaluations_per_step * substeps
        code, self.largest_error = self._advance(y, time, dt / substeps, substeps, effects,
                                                 continuing)
        return code

    def _advance(self, y, time, h, substeps, effects, continuing):
        """One compiled call: ``substeps`` steps of ``h`` in place; (code, largest error)."""
        raise NotImplementedError
