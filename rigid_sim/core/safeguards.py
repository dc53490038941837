# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Step safeguards: substeps within each method's bounds, and no non-finite state, ever.

Before a step the world asks :class:`StepGuard` how many equal substeps keep the chosen
method within its bounds (its ``bound``, a :class:`StepBound` each integrator carries):

``oscillation``  ``w h`` for the fastest spring (``sqrt(k / m_eff)``) or damper (``c / m_eff``,
                 or a damping rate), a fixed property of the scene computed once;
``rotation``     ``|omega| h`` for the bodies whose rotation the method approximates: every
                 body, or only the torqued ones for the exact-flow splittings (a torque-free
                 body moves exactly at any step). Checked again at the end of the step, so a
                 wrench that spins a body up within one step is caught and the step redone.

The bounds are numbers of this module; the integrators name theirs from here. How a step
uses the plan (and what it does about a non-finite state or a large error estimate) is
:mod:`rigid_sim.core.step_control`.
"""
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rigid_sim.core import kinematics
from rigid_sim.core.dispatch import CompiledCall

# Relative energy error the node's default integrator promises on every hard case.
ENERGY_RTOL = 1e-3
# Strang kick-drift-kick on an oscillator of frequency w conserves a modified energy; the true
# energy swings by (w h)^2 / 4 of it (at the turning points), so w h <= 2 sqrt(ENERGY_RTOL / 2)
# spends half the budget. A torque turning with the body errs the same way in |omega| h.
STRANG_BOUND = 2.0 * math.sqrt(0.5 * ENERGY_RTOL)
# Yoshida's triple jump of Strang steps: the energy swings by YOSHIDA_SWING (w h)^4, a
# coefficient measured on the harmonic oscillator (docs/stability.md, "Bounds", says how), so
# w h = (ENERGY_RTOL / (2 YOSHIDA_SWING))^(1/4) spends half the budget.
YOSHIDA_SWING = 0.076
YOSHIDA_BOUND = (ENERGY_RTOL / (2.0 * YOSHIDA_SWING)) ** 0.25
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
UNIT_QUATERNION_SLACK = kinematics.UNIT_QUATERNION_SLACK


@dataclass(frozen=True)
class StepBound:
    """The largest dimensionless step a method takes unsplit."""

    oscillation: float   # max w h over springs and dampers (inf: none)
    rotation: float      # max |omega| h (inf: none)
    rotation_all: bool   # the bound covers torque-free bodies too (their flow is not exact)
    kind: str            # what the bound protects: 'accuracy', 'stability' or 'none'


UNBOUNDED = StepBound(math.inf, math.inf, False, 'none')
# The exact-flow splittings: energy within ENERGY_RTOL; torque-free bodies move exactly at
# any step. The DLM ones approximate every body's rotation.
STRANG_ACCURACY = StepBound(STRANG_BOUND, STRANG_BOUND, False, 'accuracy')
YOSHIDA_ACCURACY = StepBound(YOSHIDA_BOUND, YOSHIDA_BOUND, False, 'accuracy')
STRANG_ACCURACY_ALL = StepBound(STRANG_BOUND, STRANG_BOUND, True, 'accuracy')
YOSHIDA_ACCURACY_ALL = StepBound(YOSHIDA_BOUND, YOSHIDA_BOUND, True, 'accuracy')
RK4_STABILITY = StepBound(RK4_BOUND, RK4_BOUND, True, 'stability')
SYMPLECTIC_EULER_STABILITY = StepBound(SYMPLECTIC_EULER_BOUND, math.inf, False, 'stability')


class SplitReason(NamedTuple):
    """Why a step was split: the numbers, put into words only when read (``str``).

    A step makes one and its reader (the node's diagnostics, once a second) is rarer:
    formatting every step's cost its node tick more than the check that found it.
    """

    kind: str              # what the bound protects (StepBound.kind)
    oscillation: float     # spring/damper rate times dt
    spin: float            # largest |omega| times dt, of the bodies the bound covers
    need: float            # fractions of the method's bounds, added
    method: str            # the integrator's name
    substeps: int          # the count taken
    capped: bool           # the need was above MAX_SUBSTEPS
    reached: bool = False  # the need was found only at the end of the step

    def __str__(self):
        words = (f'{self.kind}: spring/damper rate dt {self.oscillation:.3g} '
                 f'+ spin |omega| dt {self.spin:.3g} is {self.need:.3g} {self.method} bounds')
        if self.need <= self.substeps - 1 and not self.capped:
            words = f'{words}; {self.substeps} kept from the last step'
        if self.capped:
            words = f'{words}; capped at {MAX_SUBSTEPS} substeps'
        if self.reached:
            words = f'{words} (reached during the step)'
        return words


class StepGuard:
    """How many substeps a step of ``dt`` needs, from the state and the inputs held.

    Parameters
    ----------
    bodies : RigidBodies
        The bodies the world advances.
    effects : sequence of Effect
        The world's effects; each declares its ``fastest_rate`` and ``torqued``.
    inputs : AppliedWrenches
        The world's inputs; they torque only the bodies holding one.
    """

    def __init__(self, bodies, effects, inputs):
        self._inertia_inv = bodies.model.inertia_inv
        self._rate = max([0.0] + [effect.fastest_rate() for effect in effects])
        self._inputs = inputs
        self._always_torqued = np.zeros(bodies.count, dtype=bool)
        for effect in effects:
            self._always_torqued |= effect.torqued
        self._may_torque = bool(self._always_torqued.any() or inputs.accepts_wrench.any())
        self._last_spin = (None, None, 0.0)   # (state, inputs version, their largest |omega|)
        self._largest_spin = CompiledCall(kinematics.largest_spin)

    def plan(self, integrator, y, dt, current=1):
        """Substeps (int) and why (:class:`SplitReason`, '' for one) for a step of ``dt``.

        A spring's torque on a spinning body varies at up to the sum of the two rates, so
        the fractions of the two bounds add. ``current`` is the count of the last step: it
        is kept until the need falls well below it (see :data:`KEEP_MARGIN`).
        """
        bound = integrator.bound
        oscillation = self._rate * dt / bound.oscillation
        spin = self.spin_rate(bound, y) * dt / bound.rotation
        need = oscillation + spin
        if need <= 1.0 and current == 1:
            return 1, ''   # what follows finds too: the common end check, made short
        substeps = max(1, math.ceil(need))
        if substeps <= current:
            substeps = min(current, max(1, math.ceil(KEEP_MARGIN * need)))
        if substeps == 1:
            return 1, ''
        capped = substeps > MAX_SUBSTEPS
        substeps = min(substeps, MAX_SUBSTEPS)
        return substeps, SplitReason(bound.kind, self._rate * dt, spin * bound.rotation, need,
                                     integrator.name, substeps, capped)

    def forget(self):
        """Forget the spin measured last: its state is about to be written over (a redo)."""
        self._last_spin = (None, None, 0.0)

    def spin_rate(self, bound, y):
        """Largest ``|omega|``, rad/s, of the bodies whose rotation ``bound`` covers.

        The check at the end of a step and the plan of the next one read the same state
        object (the World replaces ``y``; a redo that writes over a state it measured first
        calls :meth:`forget`): the second is a lookup.
        """
        if bound.rotation == math.inf or not (bound.rotation_all or self._may_torque):
            return 0.0
        version = None if bound.rotation_all else self._inputs.version
        last_y, last_version, last_rate = self._last_spin
        if y is last_y and version == last_version:
            return last_rate
        rate = self._largest_spin(y, self._inertia_inv, self._always_torqued,
                                  self._inputs.held_mask, bound.rotation_all)
        self._last_spin = (y, version, rate)
        return rate
