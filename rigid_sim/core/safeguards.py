# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Step safeguards: substeps within each method's bounds, and no non-finite state, ever.

Before a step the world asks :class:`StepGuard` how many equal substeps keep the chosen
method within its bounds (:data:`BOUNDS`, keyed by integrator name):

``oscillation``  ``w h`` for the fastest spring (``sqrt(k / m_eff)``) or damper (``c / m_eff``,
                 or a damping rate), a fixed property of the scene computed once;
``rotation``     ``|omega| h`` for the bodies whose rotation the method approximates: every
                 body, or only the torqued ones for the exact-flow splittings (a torque-free
                 body moves exactly at any step). Checked again at the end of the step, so a
                 wrench that spins a body up within one step is caught and the step redone.

A step whose result holds a non-finite value is thrown away and tried again in twice as many
substeps, at most :data:`MAX_HALVINGS` times; see :meth:`rigid_sim.core.world.World.step`.
"""
import math
from dataclasses import dataclass

import numpy as np

from rigid_sim.core import rotation
from rigid_sim.core.effects.applied_wrench import AppliedWrenches
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.springs import Springs
from rigid_sim.core.state import ANGULAR_MOMENTUM, ORIENTATION

# Relative energy error the node's default integrator promises on every hard case.
ENERGY_RTOL = 1e-3
# Strang kick-drift-kick on an oscillator of frequency w conserves a modified energy; the true
# energy swings by (w h)^2 / 4 of it (at the turning points), so w h <= 2 sqrt(ENERGY_RTOL / 2)
# spends half the budget. A torque turning with the body errs the same way in |omega| h.
STRANG_BOUND = 2.0 * math.sqrt(0.5 * ENERGY_RTOL)
# Yoshida's triple jump of Strang steps: energy swings by 0.076 (w h)^4 (measured on the
# harmonic oscillator for w h <= 0.3); half the budget at w h = (ENERGY_RTOL / 0.152)^(1/4).
YOSHIDA_BOUND = (ENERGY_RTOL / 0.152) ** 0.25
# Stability limits with a 10 % margin: RK4 on an oscillator needs w h < 2 sqrt(2), symplectic
# Euler w h < 2. Both methods drift in energy at any step, so these bound stability only.
RK4_BOUND = 0.9 * 2.0 * math.sqrt(2.0)
SYMPLECTIC_EULER_BOUND = 0.9 * 2.0
# The substep count drops only when the need (the fractions of the bounds, added) has fallen
# so far that this margin over it still fits in fewer. Every change of step size moves the
# modified energy a symplectic method conserves, so a need hovering at a whole number must not
# flip the count: one body doing that 82 times in 2e4 steps erred 2.5e-4 in energy, 2.6 and 10
# times as much as with 1 or 2 substeps held (rigid_sim_bench stability, long run).
KEEP_MARGIN = 1.5
# More substeps than this would stall the caller (a node's tick); the step then runs at the
# cap and the reason says so.
MAX_SUBSTEPS = 1000
# A step with a non-finite result is retried in 2, 4, ... 2^MAX_HALVINGS times as many pieces.
MAX_HALVINGS = 4
# Integrators return unit quaternions. One off by more than this overflowed before it was
# normalised (to zeros: finite, but no rotation at all), and it is treated like a NaN.
UNIT_QUATERNION_SLACK = 1e-6


@dataclass(frozen=True)
class StepBound:
    """The largest dimensionless step a method takes unsplit."""

    oscillation: float   # max w h over springs and dampers (inf: none)
    rotation: float      # max |omega| h (inf: none)
    rotation_all: bool   # the bound covers torque-free bodies too (their flow is not exact)
    kind: str            # what the bound protects: 'accuracy', 'stability' or 'none'


UNBOUNDED = StepBound(math.inf, math.inf, False, 'none')
BOUNDS = {
    # The default: energy within ENERGY_RTOL; torque-free bodies move exactly at any step.
    'exact_split': StepBound(STRANG_BOUND, STRANG_BOUND, False, 'accuracy'),
    'exact_split4': StepBound(YOSHIDA_BOUND, YOSHIDA_BOUND, False, 'accuracy'),
    'dlm': StepBound(STRANG_BOUND, STRANG_BOUND, True, 'accuracy'),
    'dlm4': StepBound(YOSHIDA_BOUND, YOSHIDA_BOUND, True, 'accuracy'),
    'rk4': StepBound(RK4_BOUND, RK4_BOUND, True, 'stability'),
    'rk4_world': StepBound(RK4_BOUND, RK4_BOUND, True, 'stability'),
    'semi_implicit_euler': StepBound(SYMPLECTIC_EULER_BOUND, math.inf, False, 'stability'),
    # Unstable at every step (|1 + i w h| > 1): substeps would only slow the growth.
    'euler': UNBOUNDED,
    # Error-controlled: it chooses its own internal steps.
    'dopri5': UNBOUNDED,
}


@dataclass
class StepDiagnostics:
    """What the safeguards did; the node publishes it on /diagnostics."""

    substeps: int = 1         # equal substeps the last step took
    reason: str = ''          # why the last step was split ('' when it was not)
    rejected_steps: int = 0   # attempts thrown away for a non-finite value, since reset
    failed_steps: int = 0     # steps given up, the state kept as it was, since reset
    last_failure: str = ''    # what the last rejected attempt or given-up step met


def check_time_step(dt):
    """``dt`` as a float, or ValueError unless it is finite and positive, s."""
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f'time step must be finite and positive, got {dt} s')
    return dt


def oscillation_rate(effects):
    """Fastest spring frequency or damping rate of ``effects``, 1/s (0 when none)."""
    rates = [0.0]
    for effect in effects:
        if isinstance(effect, Springs):
            rates.append(effect.fastest_rate())
        elif isinstance(effect, Damping):
            rates.append(max(effect.linear, effect.angular))
    return max(rates)


class StepGuard:
    """How many substeps a step of ``dt`` needs, from arrays over the bodies.

    Parameters
    ----------
    bodies : RigidBodies
    effects : the world's effects; only springs, dampers and torques cost anything here
    """

    def __init__(self, bodies, effects):
        self._inertia_inv_rows = bodies.inertia_body_inv_rows
        self._rate = oscillation_rate(effects)
        self._wrenches = [e for e in effects if isinstance(e, AppliedWrenches)]
        # Bodies torqued whatever happens; applied wrenches torque only while one is held.
        self._always_torqued = np.zeros(bodies.count, dtype=bool)
        for effect in effects:
            if not isinstance(effect, AppliedWrenches):
                self._always_torqued |= effect.torqued
        self._may_torque = bool(self._always_torqued.any() or self._wrenches)
        self._last_spin = (None, None, 0.0)   # (state, covered bodies, their largest |omega|)

    def plan(self, integrator, y, dt, current=1):
        """Substeps (int) and the reason ('' for one) for a step of ``dt`` from ``y``.

        A spring's torque on a spinning body varies at up to the sum of the two rates, so
        the fractions of the two bounds add. ``current`` is the count of the last step: it
        is kept until the need falls well below it (see :data:`KEEP_MARGIN`).
        """
        bound = BOUNDS.get(integrator.name, UNBOUNDED)
        oscillation = self._rate * dt / bound.oscillation
        spin = self.spin_rate(bound, y) * dt / bound.rotation
        need = oscillation + spin
        substeps = max(1, math.ceil(need))
        if substeps <= current:
            substeps = min(current, max(1, math.ceil(KEEP_MARGIN * need)))
        if substeps == 1:
            return 1, ''
        reason = (f'{bound.kind}: spring/damper rate dt {self._rate * dt:.3g} '
                  f'+ spin |omega| dt {spin * bound.rotation:.3g} is {need:.3g} '
                  f'{integrator.name} bounds')
        if need <= substeps - 1:
            reason = f'{reason}; {substeps} kept from the last step'
        if substeps > MAX_SUBSTEPS:
            substeps, reason = MAX_SUBSTEPS, f'{reason}; capped at {MAX_SUBSTEPS} substeps'
        return substeps, reason

    def spin_rate(self, bound, y):
        """Largest ``|omega|``, rad/s, of the bodies whose rotation ``bound`` covers.

        The check at the end of a step and the plan of the next one read the same state
        object (the World replaces ``y``, never writes it in place): the second is a lookup.
        """
        if bound.rotation == math.inf or not (bound.rotation_all or self._may_torque):
            return 0.0
        covered = None if bound.rotation_all else self._torqued_now()
        last_y, last_covered, last_rate = self._last_spin
        if y is last_y and (covered is None if last_covered is None
                            else covered is not None and np.array_equal(covered, last_covered)):
            return last_rate
        rate = self._largest_omega(y.T, covered)
        self._last_spin = (y, covered, rate)
        return rate

    def _largest_omega(self, rows, covered):
        """Largest ``|omega|`` of the ``covered`` (N,) bool bodies (None: all) of ``rows``."""
        inertia_inv = self._inertia_inv_rows
        if covered is not None:
            if not covered.any():
                return 0.0
            if not covered.all():   # a gather only when some bodies are left out
                rows, inertia_inv = rows[:, covered], inertia_inv[:, :, covered]
        matrices = rotation.matrix_rows(rows[ORIENTATION])
        body_l = rotation.rotate_inverse_rows(matrices, rows[ANGULAR_MOMENTUM])
        omega_body = rotation.rotate_rows(inertia_inv, body_l)
        return math.sqrt(np.max(np.einsum('in,in->n', omega_body, omega_body)))

    def _torqued_now(self):
        """(N,) bool: bodies some effect may torque during the coming step."""
        torqued = self._always_torqued
        for wrenches in self._wrenches:
            torqued = torqued | wrenches.held_mask
        return torqued


def finite_steps(integrator, y, time, dt, substeps):
    """Advance ``y`` by ``dt`` in ``substeps`` equal steps, unless a step fails.

    Returns (state (N, 13) or None, '' or the failure): None at a non-finite value or a lost
    orientation. Floating-point warnings are silenced here because a non-finite result is
    handled, not reported twice.
    """
    h = dt / substeps
    try:
        with np.errstate(all='ignore'):
            for k in range(substeps):
                y = integrator.step(y, time + k * h, h)
                if not np.isfinite(y).all():
                    return None, f'non-finite state in substep {k + 1}/{substeps} of {h:.3g} s'
                q = y[:, ORIENTATION]
                if np.any(np.abs(np.einsum('ij,ij->i', q, q) - 1.0) > UNIT_QUATERNION_SLACK):
                    return None, (f'orientation lost (quaternion overflowed) in substep '
                                  f'{k + 1}/{substeps} of {h:.3g} s')
    except ArithmeticError as error:   # dopri5 raises when its step size collapses
        return None, f'{type(error).__name__}: {error}'
    return y, ''
