# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The world: a static model, the packed state, its inputs, the scene's effects, one integrator.

As a compiled engine separates model, data and inputs, the World keeps apart what never
changes while stepping (``bodies.model`` and the effects' parameter arrays), the state
``y`` (N, 13) that every step replaces, and the inputs (``inputs``: held wrenches, with their
hold ends). The integrator's kernel is compiled for exactly the listed effects.
"""
import sys

import numpy as np

from rigid_sim.core import safeguards
from rigid_sim.core.effects.base import accumulate
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.integrators import make_integrator
from rigid_sim.core.state import STATE_WIDTH, Snapshot


class World:
    """Advances all bodies together.

    Parameters
    ----------
    bodies : RigidBodies
        Masses, body-frame inertias and centres of mass of the N bodies.
    initial : (N, 13) float
        Packed Baraff state [x, q, P, L] at time 0, world frame.
    effects : sequence of Effect
        The scene's effects (see :mod:`rigid_sim.core.effects`); only what the scene lists.
    integrator : str
        A registered integrator name.
    tolerance : float
        Error target of adaptive integrators (relative, per component of the scaled state).
    auto_substep : bool
        Split steps that exceed the integrator's bounds (:mod:`rigid_sim.core.safeguards`);
        False runs the bare method, as benchmarks of the methods themselves need. Non-finite
        steps are rejected either way.
    inputs : AppliedWrenches, optional
        The wrenches held on the bodies; by default none of them takes wrench input.
    """

    def __init__(self, bodies, initial, effects=(), integrator='rk4', tolerance=1e-6,
                 auto_substep=True, inputs=None):
        self.bodies = bodies
        self.initial = np.array(initial, dtype=float)
        shape = (bodies.count, STATE_WIDTH)
        if self.initial.shape != shape or not np.isfinite(self.initial).all():
            raise ValueError(f'initial state must be a finite {shape} array, got shape '
                             f'{self.initial.shape}')
        self.effects = list(effects)
        self.inputs = (AppliedWrenches(bodies, accepts=np.zeros(bodies.count, dtype=bool))
                       if inputs is None else inputs)
        self.torqued = self.inputs.accepts_wrench.copy()
        for effect in self.effects:
            self.torqued |= effect.torqued
        self.velocity_dependent = any(e.velocity_dependent for e in self.effects)
        self._effect_parameters = tuple(effect.parameters for effect in self.effects)
        self.integrator = make_integrator(integrator, self, tolerance)
        self.auto_substep = bool(auto_substep)
        self._guard = safeguards.StepGuard(bodies, self.effects, self.inputs)
        self._restart()   # keeps wrenches the inputs were given before the world was built

    @property
    def y(self):
        """(N, 13) packed state [x, q, P, L]; a step replaces it, never writes it in place."""
        return self._y

    @y.setter
    def y(self, state):
        """Replace the state: (N, 13), read fresh by the next step."""
        self._y = np.ascontiguousarray(state, dtype=float)
        self._spare = None
        self._next_plan = None

    def effect_parameters(self):
        """Return the parameters the compiled wrench sum reads: each effect's, then the inputs'."""
        return self._effect_parameters + (self.inputs.parameters,)

    def reset(self):
        """Back to the initial state at time 0, with no wrench held.

        A held wrench belongs to the run that set it: its hold ends at a time of that run.
        """
        self._restart()
        self.inputs.release()

    def _restart(self):
        self.y = self.initial.copy()
        self.time = 0.0
        self.diagnostics = safeguards.StepDiagnostics()

    def wrench(self, snapshot):
        """Net world force and torque about the centre of mass, (N, 3) each, N and N m."""
        force = np.empty((self.bodies.count, 3))
        torque = np.empty((self.bodies.count, 3))
        accumulate(self.effect_parameters(), snapshot.y, snapshot.time, self.bodies.model,
                   force, torque)
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
        self.inputs.expire(self.time)
        substeps, reason = self._plan_from_here(dt)
        y = self._attempt(dt, substeps)
        if y is not None and self.auto_substep:
            # A wrench may spin a body up within the step: redo it if the end breaks the bound.
            grown, why = self._plan(y, dt, substeps)
            if grown > substeps:
                substeps, reason = grown, why._replace(reached=True)
                y = self._attempt(dt, substeps)
            else:   # the plan a step of dt from y will make, unless y or the inputs change
                self._next_plan = (y, dt, self.inputs.version, self.integrator, grown, why)
        diagnostics = self.diagnostics
        diagnostics.substeps, diagnostics.why = substeps, reason
        if y is None:
            diagnostics.failed_steps += 1
            return False
        self._spare, self._y = self._y, y
        self.time += dt
        return True

    def _plan_from_here(self, dt):
        """Substeps and reason for a step of ``dt`` from the current state.

        The check at the end of the last step planned it already (the dearest part of a
        one-body step after the kernel) when nothing it read has changed since: the state,
        ``dt``, the inputs held, the integrator (the node swaps it at runtime), the guard
        being on and the count kept (this step's current count is the count that check was
        given).
        """
        planned, self._next_plan = self._next_plan, None   # good for one step only
        if (planned is not None and planned[0] is self._y and planned[1] == dt
                and planned[2] == self.inputs.version and planned[3] is self.integrator
                and self.auto_substep):
            return planned[4], planned[5]
        return self._plan(self._y, dt, self.diagnostics.substeps)

    def _plan(self, y, dt, current):
        if not self.auto_substep:
            return 1, ''
        return self._guard.plan(self.integrator, y, dt, current)

    def _attempt(self, dt, substeps):
        """Step by ``dt``, halving the substeps on a non-finite state; None if every try fails."""
        for halving in range(safeguards.MAX_HALVINGS + 1):
            pieces = substeps << halving
            y = self._scratch()
            y[...] = self._y
            try:
                code = self.integrator.advance(y, self.time, dt, pieces)
                failure = safeguards.failure_message(code, pieces, dt / pieces) if code else ''
            except ArithmeticError as error:   # dopri5 raises when its step size collapses
                failure = f'{type(error).__name__}: {error}'
            if not failure:
                return y
            self.diagnostics.rejected_steps += 1
            self.diagnostics.last_failure = f't = {self.time:.6g} s: {failure}'
        return None

    def _scratch(self):
        """Return an (N, 13) array to step into.

        The state the last step replaced, when no one else holds it (a fresh array at large N
        costs page faults), else a new one.
        """
        spare = self._spare
        # References: this attribute, the local name and getrefcount's own argument.
        if spare is None or sys.getrefcount(spare) > 3 or spare is self._y:
            spare = np.empty_like(self._y)
        self._spare = None
        return spare

    def snapshot(self):
        """Kinematics of the current state."""
        return Snapshot(self.bodies, self._y, self.time)

    def energy(self):
        """Total mechanical energy, J: kinetic plus every effect's potential."""
        snapshot = self.snapshot()
        potential = sum(effect.potential_energy(snapshot) for effect in self.effects)
        return float(np.sum(snapshot.kinetic_energy()) + potential)
