# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The world: a static model, the packed state, its inputs, the scene's effects, one integrator.

As a compiled engine separates model, data and inputs, the World keeps apart what never
changes while stepping (``bodies.model`` and the effects' parameter arrays), the state
``y`` (N, 13) that every step replaces, and the inputs (``inputs``: held wrenches, with their
hold ends). The integrator's kernel is compiled for exactly the listed effects. A step is a
recipe: expire the inputs, let the step controller (:mod:`rigid_sim.core.step_control`)
advance the state, resolve the contacts when the scene lists contact
(:mod:`rigid_sim.core.contact`), record the time.
"""
import math

import numpy as np

from rigid_sim.core import safeguards
from rigid_sim.core.effects.base import accumulate
from rigid_sim.core.error_estimate import rotational_invariants
from rigid_sim.core.inputs import AppliedWrenches, EXPIRY_SLACK
from rigid_sim.core.integrators import make_integrator
from rigid_sim.core.state import STATE_WIDTH, Snapshot
from rigid_sim.core.step_control import StepController


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
        The largest local error estimate a step may keep (relative, of the scaled state:
        :mod:`rigid_sim.core.error_estimate`); the target of adaptive integrators too.
    auto_substep : bool
        Split steps that exceed the integrator's bounds (:mod:`rigid_sim.core.safeguards`);
        False runs the bare method, as benchmarks of the methods themselves need. Non-finite
        steps are rejected either way.
    inputs : AppliedWrenches, optional
        The wrenches held on the bodies; by default none of them takes wrench input.
    error_control : bool
        Split steps whose error estimate exceeds ``tolerance``; False for fixed-step studies.
    estimates : bool
        Whether anything reads the error estimates (``diagnostics``, the node's
        /diagnostics). False, allowed only without error control, says nothing does: the
        methods that can (``Integrator.estimate_optional``) step without estimating, and
        ``diagnostics.error_estimate`` reads NaN. A ValueError with error control on.
    contact : rigid_sim.core.contact.Contact, optional
        The contact stage, run after every step (:meth:`step`); None: the scene lists none.
    """

    def __init__(self, bodies, initial, effects=(), integrator='rk4', tolerance=1e-6,
                 auto_substep=True, inputs=None, error_control=True, estimates=True,
                 contact=None):
        self.bodies = bodies
        self.contact = contact
        self.initial = np.array(initial, dtype=float)
        shape = (bodies.count, STATE_WIDTH)
        if self.initial.shape != shape or not np.isfinite(self.initial).all():
            raise ValueError(f'initial state must be a finite {shape} array, got shape '
                             f'{self.initial.shape}')
        self.effects = list(effects)
        self.inputs = (AppliedWrenches(bodies, accepts=np.zeros(bodies.count, dtype=bool))
                       if inputs is None else inputs)
        self.torqued_by_effects = np.zeros(bodies.count, dtype=bool)
        for effect in self.effects:
            self.torqued_by_effects |= effect.torqued
        self.torqued = self.inputs.accepts_wrench | self.torqued_by_effects
        self.velocity_dependent = any(e.velocity_dependent for e in self.effects)
        self._effect_parameters = tuple(effect.parameters for effect in self.effects)
        self._parameters = self._effect_parameters + (self.inputs.parameters,)
        if error_control and not estimates:
            raise ValueError('error control reads the error estimates: estimates=False needs '
                             'error_control=False')
        self.estimates = bool(estimates)
        self.control = StepController(
            safeguards.StepGuard(bodies, self.effects, self.inputs),
            make_integrator(integrator, self, tolerance, self.estimates), tolerance,
            auto_substep, error_control, bodies.count)
        self._restart()   # keeps wrenches the inputs were given before the world was built

    @property
    def integrator(self):
        """Return the integrator steps are made with; it may be replaced between steps."""
        return self.control.integrator

    @integrator.setter
    def integrator(self, integrator):
        self.control.integrator = integrator

    @property
    def diagnostics(self):
        """Return what the step controller did (a :class:`~step_control.StepDiagnostics`)."""
        return self.control.diagnostics

    @property
    def y(self):
        """(N, 13) packed state [x, q, P, L]; a step replaces it, never writes it in place.

        Steps alternate between two arrays: the one read here is written again by the step
        after next, so copy it to keep it longer.
        """
        return self._y

    @y.setter
    def y(self, state):
        """Replace the state with a copy of ``state`` (N, 13), read fresh by the next step.

        The conserved quantities' drift is counted from here on.
        """
        self._y = np.array(state, dtype=float, order='C')
        self._spare = np.empty_like(self._y)
        self._take_stock()
        if self.contact is not None:
            self.contact.forget()   # the last impulses belong to the state replaced

    def _take_stock(self):
        """Note every body's ``|L|`` and rotational energy, and which hold a wrench now."""
        self.inputs.touched[:] = self.inputs.held_mask
        self._invariants = rotational_invariants(self._y, self.bodies.model.inertia_inv,
                                                 np.empty((self.bodies.count, 2)))

    def invariant_drift(self):
        """Largest relative drift of ``|L|`` and of rotational energy, bodies nothing torqued.

        Since the start, a reset or a state set from outside, over the bodies that no
        effect torques and that held no wrench in that time: they keep both exactly, so
        the drift is the integration's error. NaN for both when there is no such body.
        """
        free = ~(self.torqued_by_effects | self.inputs.touched)
        if not free.any():
            return math.nan, math.nan
        now = rotational_invariants(self._y, self.bodies.model.inertia_inv,
                                    np.empty((self.bodies.count, 2)))[free]
        start = self._invariants[free]
        drift = np.abs(now - start) / np.maximum(np.abs(start), np.finfo(float).tiny)
        return float(drift[:, 0].max()), float(drift[:, 1].max())

    def effect_parameters(self):
        """Return the parameters the compiled wrench sum reads: each effect's, then the inputs'.

        One tuple, made again only when the inputs' parameters are new (the world_point
        forces held changed): the other held wrenches are sums changed in place.
        """
        wrenches = self.inputs.parameters
        if wrenches is not self._parameters[-1]:
            self._parameters = self._effect_parameters + (wrenches,)
        return self._parameters

    def reset(self):
        """Back to the initial state at time 0, with no wrench held.

        A held wrench belongs to the run that set it: its hold ends at a time of that run.
        """
        self.inputs.release()
        self._restart()

    def _restart(self):
        self.y = self.initial
        self.time = 0.0
        self.control.restart()

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

        Returns True, or False when the step was given up: every attempt met a non-finite
        value, so ``y`` and ``time`` stay at the last good state and ``diagnostics`` says
        why. Never raises for that, so a node keeps running. Raises ValueError, changing
        nothing, for a non-finite or non-positive ``dt``.
        """
        dt = float(dt)
        if not 0.0 < dt < math.inf:   # NaN too
            raise ValueError(f'time step must be finite and positive, got {dt} s')
        inputs = self.inputs
        if inputs.next_expiry <= self.time + EXPIRY_SLACK:
            inputs.expire(self.time)
        if self.contact is None or self.contact.exact is None:
            stepped = self.control.step(self._y, self._spare, self.time, dt,
                                        self.effect_parameters(), inputs.version)
        else:   # exact mode: impacts are struck within the step, where they happen
            stepped = self.contact.exact.step(self.control, self.bodies.model, self._y,
                                              self._spare, self.time, dt,
                                              self.effect_parameters(), inputs.version)
        if stepped is None:
            return False
        # Contact changes the state the step ended at: the controller must not continue
        # from what it computed there (the end wrench, the next plan).
        if self.contact is not None and self.contact.resolve(stepped, dt, self.bodies.model):
            self.control.state_changed()
        self._spare, self._y = self._y, stepped
        self.time += dt
        return True

    def snapshot(self):
        """Kinematics of the current state."""
        return Snapshot(self.bodies, self._y, self.time)

    def energy(self):
        """Total mechanical energy, J: kinetic plus every effect's potential."""
        snapshot = self.snapshot()
        potential = sum(effect.potential_energy(snapshot) for effect in self.effects)
        return float(np.sum(snapshot.kinetic_energy()) + potential)
