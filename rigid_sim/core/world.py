# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The world: bodies, their state, the effects the scene lists, and one integrator."""
import numpy as np

from rigid_sim.core import safeguards
from rigid_sim.core.effects.applied_wrench import AppliedWrenches
from rigid_sim.core.integrators import make_integrator
from rigid_sim.core.state import STATE_WIDTH, Snapshot


class World:
    """Advances all bodies together.

    Parameters
    ----------
    bodies : RigidBodies
    initial : (N, 13) float, packed Baraff state at time 0
    effects : list of effects (see :mod:`rigid_sim.core.effects`); only what the scene lists
    integrator : str, a registered integrator name
    tolerance : float, error target of adaptive integrators
    auto_substep : bool, split steps that exceed the integrator's bounds
        (:mod:`rigid_sim.core.safeguards`); False runs the bare method, as benchmarks of the
        methods themselves need. Non-finite steps are rejected either way.
    """

    def __init__(self, bodies, initial, effects=(), integrator='rk4', tolerance=1e-6,
                 auto_substep=True):
        self.bodies = bodies
        self.initial = np.array(initial, dtype=float)
        shape = (bodies.count, STATE_WIDTH)
        if self.initial.shape != shape or not np.isfinite(self.initial).all():
            raise ValueError(f'initial state must be a finite {shape} array, got shape '
                             f'{self.initial.shape}')
        self.effects = list(effects)
        self.torqued = np.zeros(bodies.count, dtype=bool)
        for effect in self.effects:
            self.torqued |= effect.torqued
        self.velocity_dependent = any(e.velocity_dependent for e in self.effects)
        self._expiring = [e for e in self.effects if hasattr(e, 'expire')]
        self.integrator = make_integrator(integrator, self, tolerance)
        self.auto_substep = bool(auto_substep)
        self._guard = safeguards.StepGuard(bodies, self.effects)
        self._restart()   # keeps wrenches the effects were given before the world was built

    def effect(self, kind):
        """Return the effect of class ``kind`` in this world, or None when the scene has none."""
        return next((e for e in self.effects if isinstance(e, kind)), None)

    def reset(self):
        """Back to the initial state at time 0, with no wrench held.

        A held wrench belongs to the run that set it: its hold ends at a time of that run.
        """
        self._restart()
        applied = self.effect(AppliedWrenches)
        if applied is not None:
            applied.release()

    def _restart(self):
        self.y = self.initial.copy()
        self.time = 0.0
        self.diagnostics = safeguards.StepDiagnostics()

    def wrench(self, snapshot):
        """Net world force and torque about the centre of mass, (N, 3) each."""
        force = np.zeros((self.bodies.count, 3))
        torque = np.zeros((self.bodies.count, 3))
        for effect in self.effects:
            effect.accumulate(snapshot, force, torque)
        return force, torque

    def net_wrench(self):
        """Net world force and torque about the centre of mass now, (N, 3) each, N and N m."""
        return self.wrench(self.snapshot())

    def step(self, dt):
        """Advance every body by ``dt`` seconds of simulated time, in substeps if needed.

        Returns True, or False when the step was given up: every attempt (down to
        ``2^MAX_HALVINGS`` times smaller) met a non-finite value, so ``y`` and ``time`` stay
        at the last good state and ``diagnostics`` says why. Never raises for that, so a
        node keeps running. Raises ValueError, changing nothing, for a non-finite or
        non-positive ``dt``.
        """
        dt = safeguards.check_time_step(dt)
        for effect in self._expiring:
            effect.expire(self.time)
        substeps, reason = self._plan(self.y, dt, self.diagnostics.substeps)
        y = self._attempt(dt, substeps)
        if y is not None and self.auto_substep:
            # A wrench may spin a body up within the step: redo it if the end breaks the bound.
            grown, why = self._plan(y, dt, substeps)
            if grown > substeps:
                substeps, reason = grown, why + ' (reached during the step)'
                y = self._attempt(dt, substeps)
        diagnostics = self.diagnostics
        diagnostics.substeps, diagnostics.reason = substeps, reason
        if y is None:
            diagnostics.failed_steps += 1
            return False
        self.y = y
        self.time += dt
        return True

    def _plan(self, y, dt, current):
        if not self.auto_substep:
            return 1, ''
        return self._guard.plan(self.integrator, y, dt, current)

    def _attempt(self, dt, substeps):
        """Return the state after ``dt``, retried in more substeps if non-finite (None: failed)."""
        for halving in range(safeguards.MAX_HALVINGS + 1):
            y, failure = safeguards.finite_steps(self.integrator, self.y, self.time, dt,
                                                 substeps << halving)
            if y is not None:
                return y
            self.diagnostics.rejected_steps += 1
            self.diagnostics.last_failure = f't = {self.time:.6g} s: {failure}'
        return None

    def snapshot(self):
        """Kinematics of the current state."""
        return Snapshot(self.bodies, self.y, self.time)

    def energy(self):
        """Total mechanical energy, J: kinetic plus every effect's potential."""
        snapshot = self.snapshot()
        potential = sum(effect.potential_energy(snapshot) for effect in self.effects)
        return float(np.sum(snapshot.kinetic_energy()) + potential)
