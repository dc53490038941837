# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Exact mode: an impact is struck at the moment it happens, not where the step ends.

A step of the world is made as always, by the step controller (error-controlled). If the
state it ended at has pairs struck (:func:`~rigid_sim.core.contact.impact.struck_pairs`:
overlapping and closing faster than the resting speed, apart at the start), the moment of
the first impact is the root of their least gap along the state integrated from the
step's start (Brent's method, scipy's ``brentq``); the world is integrated to that moment,
the impulses are struck there (:func:`~rigid_sim.core.contact.impact.strike`) and the step
controller makes the rest of the step, which may strike again. Contacts closing slower
than the resting speed stay with the velocity-level stage the World runs after the step,
so a bouncing body comes to rest instead of bouncing ever smaller (no Zeno).

The root's trial states are integrated by the world's integrator in as many substeps per
second as the step controller took for the step it accepted: the trajectory to the impact
is that step's, so the error control that accepted it holds there too.
"""
import math

import numpy as np
from scipy.optimize import brentq

# Impacts struck within one step at most, so a tick stays bounded (bodies rattling in a
# narrow gap); the step's later impacts are left to the velocity-level stage at its end.
MAX_IMPACTS = 64
# The moment of an impact is found to this fraction of the step (Brent's method converges
# superlinearly: 5 trial states an impact for the bounce of test_contact_exact.py).
ROOT_TOLERANCE = 1e-12


class _Lost(Exception):
    """A trial state met a non-finite value: no root is sought in this step."""


class ExactSteps:
    """Steps of one world in exact mode; keeps the scratch states the root finder uses.

    Parameters
    ----------
    contact : rigid_sim.core.contact.Contact
        The world's contact stage, in exact mode.
    bodies : int
        How many bodies the world has.
    """

    def __init__(self, contact, bodies):
        self.contact = contact
        self.impacts = 0   # impacts struck in the last step
        self._trial = np.empty((bodies, 13))
        self._here = np.empty((bodies, 13))

    def step(self, control, model, y, into, time, dt, effects, version):
        """Advance ``y`` by ``dt`` into ``into``, striking every impact where it happens.

        As :meth:`~rigid_sim.core.step_control.StepController.step`: returns ``into``, or
        None when the step was given up.
        """
        stepped = control.step(y, into, time, dt, effects, version)
        start, spent, self.impacts = y, 0.0, 0
        while stepped is not None and self.impacts < MAX_IMPACTS:
            span = dt - spent
            moment = self._first_impact(control, model, start, stepped, time + spent, span,
                                        effects)
            if moment is None:
                break
            here = self._here
            try:
                self._integrate(control.integrator, start, here, time + spent, moment, span,
                                control.diagnostics.substeps, effects)
            except (_Lost, ArithmeticError):
                break   # ``into`` holds the piece's end: the velocity-level stage acts
            if not self.contact.strike(here, model):
                break   # the gap and the contacts disagree: the velocity-level stage acts
            self.impacts += 1
            start, spent = here, spent + moment
            if moment < span:
                stepped = control.step(here, into, time + spent, dt - spent, effects, version)
            else:   # struck at the step's very end
                into[...] = here
        if self.impacts:
            control.state_changed()   # the controller's last step was a piece of this one
        return stepped

    def _first_impact(self, control, model, start, end, time, span, effects):
        """Seconds from ``start`` to the first impact of the piece ending at ``end``; None."""
        struck = self.contact.struck(start, end, model)
        if not struck:
            return None
        integrator, substeps = control.integrator, control.diagnostics.substeps
        known = {}   # brentq asks for the bracket's ends again: each is integrated once

        def gap(moment):
            if moment not in known:
                self._integrate(integrator, start, self._trial, time, moment, span, substeps,
                                effects)
                known[moment] = self.contact.least_gap(self._trial, struck)
            return known[moment]

        try:
            # The trial of the whole piece may differ from the step the controller made by
            # round-off (a first-same-as-last method continuing): then no bracket, and the
            # velocity-level stage takes the impact at the step's end.
            if not gap(span) < 0.0:
                return None
            return brentq(gap, 0.0, span, xtol=ROOT_TOLERANCE * span)
        except (_Lost, ArithmeticError):   # a non-finite trial; dopri5's collapsed step
            return None

    @staticmethod
    def _integrate(integrator, start, into, time, moment, span, substeps, effects):
        """``into`` = ``start`` integrated by ``moment`` s of a piece of ``span`` s.

        In as many substeps per second as the controller took for the piece.
        """
        into[...] = start
        if moment > 0.0:
            pieces = max(1, math.ceil(substeps * moment / span))
            if integrator.advance(into, time, moment, pieces, effects):
                raise _Lost
