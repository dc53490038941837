# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The step controller: how one step of ``dt`` becomes calls of an integrator.

A step is planned, attempted, checked and recorded, in this module alone:

1. **Plan** the equal substeps: the integrator's bounds (:class:`~safeguards.StepGuard`)
   and, with error control, the count the last step's error estimate predicts for
   ``tolerance`` (the estimate per step falls as ``n^-estimate_order`` with ``n`` substeps).
2. **Attempt**: one integrator call; a non-finite result is thrown away and tried again in
   twice as many substeps, at most :data:`MAX_HALVINGS` times.
3. **Check the end**: a wrench may have spun a body beyond the bound within the step, or
   the error estimate may exceed ``tolerance``; either asks for more substeps and the step
   is attempted again with them (at most :data:`MAX_REDOS` times).
4. **Record** what was done in :class:`StepDiagnostics`, failures in words.

Error control raises the count only for a step whose estimate exceeded ``tolerance``, to the
count that aims at :data:`ERROR_TARGET` of it, and then holds that count (whatever the bounds
would give back) until the estimate has fallen by :data:`~safeguards.KEEP_MARGIN` below it.
Between the two the count stays: a count that followed an estimate hovering at the aim flipped
with the orbit, and each flip of a symplectic method's step costs it the modified energy it
keeps (docs/stability.md, "Error control holds its count too").
"""
import math
from dataclasses import dataclass
from typing import NamedTuple

from rigid_sim.core import safeguards
from rigid_sim.core.integrators.adaptive import StepsCapped

# A step with a non-finite result is retried in 2, 4, ... 2^MAX_HALVINGS times as many pieces.
MAX_HALVINGS = 4
# Error control splits a step into at most this many body-substeps (substeps times bodies,
# and never more than safeguards.MAX_SUBSTEPS substeps): about 40 ms of rk4 or 0.14 s of
# exact_split on this machine, so that a tolerance set very small on a large scene leaves a
# tick bounded (a node's services wait for it); the reason then says it was capped.
ERROR_WORK = 200_000
# A step is redone at most this many times with the counts its end checks ask for; the
# estimate's prediction is good to a few percent in smooth motion, so one redo is the rule.
MAX_REDOS = 3
# Error control aims at this fraction of the tolerance, so that the estimate of the next step,
# which the state may have made a little larger, stays below it without a redo, and so that
# errors that add up over a run (a dissipative method's energy) stay near the tolerance's
# intent: rk4 on the thin rod of test_node_error_estimates, tolerance 1e-6, 100 Hz, keeps |L|
# within 1.4e-5 and energy within 2.7e-5 over 5 s at 0.25 in 9.0 substeps a step (2.8e-5 in
# 8.5 at 0.3, 3.1e-5 in 8.1 at 0.5; a World run, the count raised only above the tolerance).
ERROR_TARGET = 0.25


@dataclass
class StepDiagnostics:
    """What the step controller did; the node publishes it on /diagnostics."""

    substeps: int = 1         # equal substeps the last step took
    why: object = ''          # SplitReason or ErrorReason of the last step ('' when unsplit)
    rejected_steps: int = 0   # attempts thrown away for a non-finite value, since reset
    failed_steps: int = 0     # steps given up, the state kept as it was, since reset
    last_failure: str = ''    # what the last rejected attempt or given-up step met
    error_estimate: float = 0.0      # largest local error estimate of the last step
    accumulated_error: float = 0.0   # sum of every step's, since reset
    redone_steps: int = 0     # steps attempted again with more substeps, since reset

    @property
    def reason(self):
        """Why the last step was split, in words ('' when it was not)."""
        return str(self.why)


class ErrorReason(NamedTuple):
    """Why error control split a step: the numbers, in words only when read (``str``)."""

    estimate: float      # the error estimate that asked for the substeps
    tolerance: float
    method: str          # the integrator's name
    substeps: int        # the count taken
    capped: bool         # more were needed than the cap (the count taken)

    def __str__(self):
        words = (f'error: estimate {self.estimate:.3g} against tolerance {self.tolerance:.3g} '
                 f'needs {self.substeps} {self.method} substeps')
        if self.capped:
            words = f'{words}; capped at {self.substeps} substeps (ERROR_WORK)'
        return words


def failure_message(code, substeps, h):
    """Describe in words what an integrator's failure ``code`` (see ``Integrator.advance``) met."""
    where = f'substep {abs(code)}/{substeps} of {h:.3g} s'
    if code > 0:
        return f'non-finite state in {where}'
    return f'orientation lost (quaternion overflowed) in {where}'


class StepController:
    """Plans, attempts, checks and records the steps of one world.

    Parameters
    ----------
    guard : safeguards.StepGuard
        The substeps the integrator's bounds need.
    integrator : Integrator
        The method; the node may replace it between steps (``integrator``).
    tolerance : float
        The largest error estimate a step may keep, in the units of
        :mod:`rigid_sim.core.error_estimate`.
    auto_substep : bool
        Split steps by the method's bounds; False runs the bare method.
    error_control : bool
        Split steps by the error estimate; False keeps the count the bounds give (fixed-step
        studies). Adaptive methods control their error themselves either way.
    bodies : int
        How many bodies a step advances: error control's cap is :data:`ERROR_WORK` over it.
    """

    def __init__(self, guard, integrator, tolerance, auto_substep, error_control, bodies=1):
        self.guard = guard
        self._error_cap = max(1, min(safeguards.MAX_SUBSTEPS, ERROR_WORK // bodies))
        self.integrator = integrator
        self.tolerance = float(tolerance)
        self.auto_substep = bool(auto_substep)
        self.error_control = bool(error_control)
        self.diagnostics = StepDiagnostics()
        self._next_plan = None   # the end check's plan for the next step: (dt, count, why)
        self._ended = None       # (state, inputs version, integrator) the last step ended at
        self._error_held = 0     # the count error control last asked for (0: none), held

    def restart(self):
        """Forget the past: a state set from outside or a reset."""
        self.diagnostics = StepDiagnostics()
        self._next_plan = self._ended = None
        self._error_held = 0

    def state_changed(self):
        """Start afresh: the state the last step ended at was changed after it (by contact)."""
        self._ended = self._next_plan = None

    def step(self, y, into, time, dt, effects, version):
        """Advance ``y`` by ``dt`` into the array ``into``; ``into``, or None if given up.

        ``effects`` are the parameters to sum, ``version`` the inputs' version (a change
        means the wrenches changed). ``y`` is never written. The common step (planned as
        the last one ended, one attempt, nothing to redo) makes few Python calls: at one
        body they are most of a step.
        """
        ended, integrator = self._ended, self.integrator
        continuing = (ended is not None and ended[0] is y and ended[1] == version
                      and ended[2] is integrator)
        substeps, why = self._plan(y, dt, continuing)
        failed = self._attempt(y, into, time, dt, substeps, effects, continuing)
        if failed and not self._retry(y, into, time, dt, substeps, effects, failed):
            return self._record(None, substeps, why, version)
        if self.auto_substep or (self.error_control
                                 and integrator.largest_error > self.tolerance):
            redo = self._check_end(into, dt, substeps)
            if redo is not None:
                return self._redo(y, into, time, dt, effects, version, redo)
        return self._record(into, substeps, why, version)

    def _redo(self, y, into, time, dt, effects, version, redo):
        """Attempt the step again with the (substeps, why) its end asks for, and record it.

        At most :data:`MAX_REDOS` times; the end of the last attempt is not checked, so the
        next step plans afresh. Each attempt writes over ``into``: what the end check
        measured of it (the spin, the next step's plan) goes with it.
        """
        for redone in range(1, MAX_REDOS + 1):
            substeps, why = redo
            self.diagnostics.redone_steps += 1
            self.guard.forget()
            self._next_plan = None
            failed = self._attempt(y, into, time, dt, substeps, effects, False)
            if failed and not self._retry(y, into, time, dt, substeps, effects, failed):
                return self._record(None, substeps, why, version)
            if redone == MAX_REDOS or (redo := self._check_end(into, dt, substeps)) is None:
                return self._record(into, substeps, why, version)

    def _plan(self, y, dt, continuing):
        """Substeps and why for a step of ``dt`` from ``y``: the bounds', or the error's.

        The bounds' plan is the one the last step's end check made for a step of ``dt``
        from where it ended (:meth:`_check_end`), unless that step is not ``continuing``.
        """
        if self.auto_substep:
            planned, self._next_plan = self._next_plan, None   # good for one step only
            if continuing and planned is not None and planned[0] == dt:
                substeps, why = planned[1], planned[2]
            else:
                substeps, why = self.guard.plan(self.integrator, y, dt, self.diagnostics.substeps)
        else:
            substeps, why = 1, ''
        wanted = self._error_plan() if continuing and self.error_control else 0
        self._error_held = wanted if wanted > 1 else 0
        if wanted > substeps:
            capped = wanted > self._error_cap
            substeps = min(wanted, self._error_cap)
            why = ErrorReason(self.diagnostics.error_estimate, self.tolerance,
                              self.integrator.name, substeps, capped)
        return substeps, why

    def _error_plan(self):
        """Substeps error control asks of this step (0: nothing, the bounds' count stands).

        More than the last step took only if its estimate exceeded the tolerance (a step kept
        above it: capped, or redone to the limit); the count error control asked for before
        is held until the estimate has fallen far enough below the aim to give some back.
        """
        estimate = self.diagnostics.error_estimate
        if not estimate < math.inf or self.integrator.adaptive:
            return 0
        held = self.diagnostics.substeps
        need = self._need(held, estimate)
        if estimate > self.tolerance:
            return math.ceil(need)
        if not self._error_held:
            return 0
        if need * safeguards.KEEP_MARGIN > held:
            return held   # not far enough below to give substeps back
        return max(1, math.ceil(need))

    def _need(self, substeps, estimate):
        """Substeps (a real number) that bring ``estimate``, made in ``substeps``, to the aim.

        The estimate of a step falls as ``n^-estimate_order`` with ``n`` substeps.
        """
        return substeps * (estimate / (ERROR_TARGET * self.tolerance)) ** (
            1.0 / self.integrator.estimate_order)

    def _attempt(self, y, into, time, dt, substeps, effects, continuing):
        """Step ``y`` by ``dt`` into ``into`` in ``substeps``: 0, a failure code or an error."""
        into[...] = y
        try:
            return self.integrator.advance(into, time, dt, substeps, effects, continuing)
        except ArithmeticError as error:   # dopri5 raises when its step size collapses
            return error

    def _retry(self, y, into, time, dt, substeps, effects, failed):
        """Count the failed attempt and retry in 2, 4, ... times the pieces; False if all fail.

        ``failed`` is what the attempt in ``substeps`` returned (a failure code or an error).
        An attempt that ran into its method's cap on work (:class:`StepsCapped`) is not
        retried: more pieces would take as many steps again, each capped.
        """
        pieces = substeps
        if isinstance(failed, StepsCapped):
            self._fail(time, dt, pieces, failed)
            return False
        for _ in range(MAX_HALVINGS):
            self._fail(time, dt, pieces, failed)
            pieces <<= 1
            failed = self._attempt(y, into, time, dt, pieces, effects, False)
            if not failed:
                return True
        self._fail(time, dt, pieces, failed)
        return False

    def _fail(self, time, dt, pieces, failed):
        """Count a rejected attempt in ``pieces`` and say what it met (a code or an error)."""
        self.diagnostics.rejected_steps += 1
        failure = (failure_message(failed, pieces, dt / pieces) if isinstance(failed, int)
                   else f'{type(failed).__name__}: {failed}')
        self.diagnostics.last_failure = f't = {time:.6g} s: {failure}'

    def _check_end(self, y, dt, substeps):
        """(substeps, why) to redo the step with, or None to keep it.

        A wrench may spin a body up within the step: the end state breaks the bound. The
        estimate may exceed the tolerance: the count it predicts, aimed below it.
        """
        if self.auto_substep:
            grown, why = self.guard.plan(self.integrator, y, dt, substeps)
            if grown > substeps:
                return grown, why._replace(reached=True)
            # The plan a step of dt from y will make, if the next step continues this one.
            self._next_plan = (dt, grown, why)
        estimate = self.integrator.largest_error
        if (self.tolerance < estimate < math.inf and self.error_control
                and not self.integrator.adaptive and substeps < self._error_cap):
            need = self._need(substeps, estimate)
            wanted = min(max(substeps + 1, math.ceil(need)), self._error_cap)
            return wanted, ErrorReason(estimate, self.tolerance, self.integrator.name, wanted,
                                       need > self._error_cap)
        return None

    def _record(self, y, substeps, why, version):
        """Write the step into the diagnostics; ``y`` (None: given up) is what the step returns."""
        diagnostics = self.diagnostics
        diagnostics.substeps, diagnostics.why = substeps, why
        if isinstance(why, ErrorReason):   # a redo's count: error control asked for it
            self._error_held = substeps
        if y is None:
            diagnostics.failed_steps += 1
            self._ended = self._next_plan = None
            return None
        estimate = self.integrator.largest_error
        diagnostics.error_estimate = estimate
        diagnostics.accumulated_error += estimate
        self._ended = (y, version, self.integrator)
        return y
