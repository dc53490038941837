# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The contract every integrator fulfils.

An integrator advances the packed Baraff state ``y`` (N, 13) = [x, q, P, L] of all bodies.
It is built for a *system* (a :class:`~rigid_sim.core.world.World`), which provides

``bodies``
    the :class:`~rigid_sim.core.state.RigidBodies` (``bodies.model``: the static arrays);
``effect_parameters()``
    the tuple of the parameters of the scene's effects and of its inputs, which
    :func:`rigid_sim.core.effects.base.accumulate` sums in compiled code;
``velocity_dependent``
    bool, whether any effect's wrench depends on the momenta.

To write a new method, subclass :class:`Integrator`, set ``name``, ``order``, ``bound``
(from :mod:`rigid_sim.core.safeguards`) and ``evaluations_per_step``, implement
``_advance`` with one compiled call, and add the class to the registry in
``integrators/__init__.py``. Quaternions leave every step unit.
"""
import numpy as np


class Integrator:
    """Base class: steps of ``h`` for every body at once, in place, in compiled code."""

    name = ''
    order = 0          # global order of accuracy
    adaptive = False   # True: ``tolerance`` controls the error, not ``dt``
    # bound: the largest step it takes unsplit, a safeguards.StepBound that every method
    # declares for itself (registration refuses one that does not).
    evaluations_per_step = 1       # wrench evaluations of one step

    def __init__(self, system, tolerance=1e-6):
        self.system = system
        self.bodies = system.bodies
        self.tolerance = float(tolerance)
        self.evaluations = 0     # wrench evaluations since construction
        self.last_substeps = 1   # internal steps the last call took (adaptive methods)
        count = self.bodies.count
        self._force = np.zeros((count, 3))
        self._torque = np.zeros((count, 3))

    def step(self, y, time, dt):
        """State (N, 13) ``dt`` seconds after ``y`` (N, 13) at ``time``; ``y`` stays as it is."""
        state = np.array(y, dtype=float, order='C')
        self.advance(state, time, dt, 1)
        return state

    def advance(self, y, time, dt, substeps):
        """Advance ``y`` (N, 13, C-contiguous) in place by ``dt`` in ``substeps`` equal steps.

        Returns 0, or the failure code of the first bad substep ``k`` (1-based): ``k`` for a
        non-finite state, ``-k`` for a quaternion that overflowed before it was normalised
        (see :func:`rigid_sim.core.safeguards.failure_message`). ``y`` is then garbage.
        """
        self.evaluations += self.evaluations_per_step * substeps
        return self._advance(y, time, dt / substeps, substeps)

    def _advance(self, y, time, h, substeps):
        """One compiled call: ``substeps`` steps of ``h`` in place; the code of ``advance``."""
        raise NotImplementedError
