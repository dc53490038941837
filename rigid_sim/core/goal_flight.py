# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A goal's flight: the world's steps from now to the goal's time, rolled out two ways.

:class:`Flight` is the time grid (``steps`` steps of ``dt`` from the world's time), the
substeps each step takes and the wrenches held meanwhile, whose holds end at steps of the
grid. :class:`Rollout` flies copies of the goal's body over it in compiled calls
(:mod:`~rigid_sim.core.goal_copies`); :func:`fly_world` flies a copy of the whole World
with ``World.step``, which is what the world itself will do: the substeps its step guard
picks depend on every body's spin and are known only along the way, so the solver's last
word is always that of :func:`fly_world`, except for a free flight under the exact flow,
which is exact at any step.
"""
import copy
import math

import numpy as np

from rigid_sim.core import safeguards
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.goal_contact import ContactSteps
from rigid_sim.core.goal_copies import Copies
from rigid_sim.core.inputs import EXPIRY_SLACK, WrenchInputs
from rigid_sim.core.integrators.splitting import EXACT_DRIFT
from rigid_sim.core.world import World

GOAL_KEY = 'goal'     # the key under which a solved wrench is held
PATH_POSES = 100      # poses of a predicted path, at most


class GoalRefused(ValueError):
    """A goal that cannot be reached within the scene's limits; nothing was changed."""


def collides(world, index):
    """Whether body ``index`` has a collision shape in a scene with contact."""
    return world.contact is not None and world.contact.parameters.kind[index] != 0


def free_under_exact_flow(world, index, held):
    """Whether the world's integrator moves body ``index`` exactly at any step.

    The exact-flow splittings drift by the closed-form torque-free motion and kick with
    the wrench, which is exact when nothing torques the body and its force is constant:
    gravity only (no spring on it, no damper, no wrench in ``held``, AppliedWrenches),
    and nothing it could collide with.
    """
    return (getattr(world.integrator, 'drift', None) == EXACT_DRIFT
            and not held.held_mask[index] and not collides(world, index)
            and not any(effect.torqued[index] or isinstance(effect, Damping)
                        for effect in world.effects))


def copy_held(held, bodies):
    """Return a copy of ``held`` (AppliedWrenches) that shares ``bodies`` (RigidBodies)."""
    return copy.deepcopy(held, {id(bodies): bodies})


def held_without_goal(world, index):
    """Return the world's held wrenches less body ``index``'s goal wrench (then a copy).

    A new goal replaces the body's last one, wrench and all.
    """
    inputs = world.inputs
    if (index, GOAL_KEY) not in inputs.held:
        return inputs
    held = copy_held(inputs, world.bodies)
    held.release(index, GOAL_KEY)
    return held


class Flight:
    """``steps`` steps of ``dt`` from ``t0``, with the substeps and wrenches of each.

    Parameters
    ----------
    world : rigid_sim.core.world.World
    steps, dt : int, float
        The grid: ``dt`` is the size of one ``World.step``.
    held : rigid_sim.core.inputs.AppliedWrenches
        The wrenches held at ``t0``, read only (see :func:`held_without_goal`).
    """

    def __init__(self, world, steps, dt, held):
        self.t0, self.steps, self.dt = world.time, steps, dt
        self.bodies = world.bodies
        self.arrival = world.time + steps * dt
        self.held = held
        self.plan = [(steps, 1)]   # runs of (steps, substeps per step)
        self._held_segments = None

    def _hold_timeline(self):
        """[(first step, WrenchInputs)]: what is held from that step on.

        The arrays are the held wrenches' own when nothing runs out during the flight
        (the rollouts copy them at once), else copies.
        """
        ends = sorted({math.ceil((w.expires - EXPIRY_SLACK - self.t0) / self.dt)
                       for w in self.held.held.values() if w.expires < np.inf})
        ends = [k for k in ends if 0 < k < self.steps]
        if not ends:
            return [(0, self.held.parameters)]
        timeline, timing = [], copy_held(self.held, self.bodies)
        for first in [0] + ends:
            timing.expire(self.t0 + first * self.dt)
            timeline.append((first, WrenchInputs(*(np.array(a) for a in timing.parameters))))
        return timeline

    def segments(self):
        """[(first step, steps, substeps, WrenchInputs)] of constant substeps and holdings."""
        if self._held_segments is None:
            self._held_segments = self._hold_timeline()
        cuts = {0, self.steps} | {first for first, _ in self._held_segments}
        start = 0
        for steps, _ in self.plan:
            start += steps
            cuts.add(start)
        cuts = sorted(cuts)
        result = []
        for first, end in zip(cuts[:-1], cuts[1:]):
            held = [p for k, p in self._held_segments if k <= first][-1]
            result.append((first, end - first, self.substeps_at(first), held))
        return result

    def substeps_at(self, step):
        """Return the substeps of step ``step`` in the plan."""
        for steps, substeps in self.plan:
            if step < steps:
                return substeps
            step -= steps
        return self.plan[-1][1]

    def plan_from(self, world, y):
        """Plan every step as the world's guard would plan the first one from state ``y``."""
        if not world.control.auto_substep:
            return
        guard = safeguards.StepGuard(world.bodies, world.effects, self.held)
        substeps, _ = guard.plan(world.integrator, y, self.dt, world.diagnostics.substeps)
        self.plan = [(self.steps, substeps)]


class Rollout:
    """Flights of ``copies`` copies of a body at once, over a :class:`Flight`.

    Parameters
    ----------
    world : rigid_sim.core.world.World
    index : int
        The goal's body.
    copies : int
    wrench_axes : str or None
        'world' or 'body' when the unknowns are a wrench held through the flight.
    """

    def __init__(self, world, index, copies, wrench_axes=None):
        self.copies = Copies(world, index, copies)
        # How the rows are stepped: through the planes where the scene's contact is exact
        # and the group collides (velocity mode: see GoalProblem.verified), else freely.
        self.stepper = self.copies
        contact = world.contact
        if (contact is not None and contact.exact is not None
                and contact.parameters.kind[self.copies.rows].any()):
            self.stepper = ContactSteps(contact, self.copies)
        self.targets = self.copies.target_rows()
        self.wrench_axes = wrench_axes
        self._segments = []
        self._start = None

    def prepare(self, flight, y):
        """Fly from the world state ``y`` (N, 13) over ``flight`` from now on."""
        self._start = np.ascontiguousarray(np.tile(y[self.copies.rows], (self.copies.copies, 1)))
        self._flight = flight
        self._segments = []
        for first, steps, substeps, held in flight.segments():
            inputs = self.copies.copy_inputs(held)
            sums = inputs.body_sum if self.wrench_axes == 'body' else inputs.world_sum
            self._segments.append((first, steps, substeps, inputs, sums,
                                   sums[self.targets].copy()))

    def fly(self, rows, wrench=None, every=0):
        """Fly the body from its start ``rows`` (copies, 13); its final states and path.

        ``wrench`` (copies, 6): force and torque held on top of the flight's wrenches, in
        ``wrench_axes``. Rows that met a non-finite value are NaN. With ``every`` > 0, also
        the path: [(time, (copies, 13) states)] every ``every`` steps and at the end.
        """
        y = self._start.copy()
        y[self.targets] = rows
        self.stepper.begin(self._start[:self.copies.width])
        t0, dt = self._flight.t0, self._flight.dt
        path = [(t0, y[self.targets].copy())] if every else []
        for first, steps, substeps, inputs, sums, base in self._segments:
            if wrench is not None:
                sums[self.targets] = base + wrench
                inputs.body_held[self.targets] |= self.wrench_axes == 'body'
            self.copies.inputs = inputs
            done = 0
            while done < steps:
                # To the next recorded step, or through the segment.
                chunk = steps - done
                if every:
                    chunk = min(chunk, every - (first + done) % every)
                self.stepper.advance(y, t0 + (first + done) * dt, chunk, dt, substeps)
                done += chunk
                if every:
                    path.append((t0 + (first + done) * dt, y[self.targets].copy()))
        final = y[self.targets]
        final[~np.isfinite(final).all(axis=1)] = np.nan
        return final, path


def snapshot(world, y=None, held=None):
    """Return a World that steps as ``world`` would from here, without touching it.

    Its own copy of the state (``y``, default the world's), time, step guard's count,
    integrator, held wrenches (``held``, default the world's) and contact stage (with the
    world's warm start); the bodies and the effects' parameters, which stepping never
    changes, are shared.
    """
    control = world.control
    copied = World(world.bodies, world.y if y is None else y, world.effects,
                   world.integrator.name, control.tolerance, control.auto_substep,
                   inputs=copy_held(world.inputs if held is None else held, world.bodies),
                   error_control=control.error_control)
    copied.time = world.time
    copied.diagnostics.substeps = world.diagnostics.substeps
    if world.contact is not None:   # after the state is set, which drops the warm start
        copied.contact = world.contact.duplicate()
    return copied


def fly_world(world, y, flight, wrench=None, axes='world', index=None, path_every=0):
    """Fly a copy of ``world`` from state ``y`` over ``flight`` with ``World.step``.

    Parameters
    ----------
    world : rigid_sim.core.world.World
        Left as it is: the copy has its own state, time, integrator and held wrenches.
    y : (N, 13) float
        The state to start from (the goal's unknowns applied).
    flight : Flight
        Its grid of steps and the wrenches held.
    wrench : (6,) float, optional
        Force and torque held on body ``index`` in ``axes`` under :data:`GOAL_KEY` until
        the arrival.
    axes : str
        'world' or 'body'.
    index : int
        The goal's body.
    path_every : int
        Record body ``index``'s state every this many steps (0: never).

    Returns
    -------
    final : (N, 13) float, or None when the world gave a step up
    plan : list of (steps, substeps) runs the world's guard chose
    path : list of (time, (13,) state) of body ``index``
    capped : bool, whether a step needed more than the guard's cap of substeps
    touched : bool, whether body ``index`` was in a contact where a step ended
    """
    copied = snapshot(world, y, flight.held)
    if wrench is not None:
        copied.inputs.hold(index, GOAL_KEY, axes, wrench[:3], wrench[3:],
                           expires=flight.arrival)
    plan, path, capped = [], [(copied.time, y[index].copy())] if path_every else [], False
    touched = False
    for step in range(flight.steps):
        if not copied.step(flight.dt):
            return None, plan, path, capped, touched
        substeps = copied.diagnostics.substeps
        capped |= bool(copied.diagnostics.why) and copied.diagnostics.why.capped
        if copied.contact is not None and copied.contact.count:
            touched |= bool((copied.contact.contacts()[0] == index).any())
        if plan and plan[-1][1] == substeps:
            plan[-1] = (plan[-1][0] + 1, substeps)
        else:
            plan.append((1, substeps))
        if path_every and ((step + 1) % path_every == 0 or step + 1 == flight.steps):
            path.append((copied.time, copied.y[index].copy()))
    return copied.y, plan, path, capped, touched
