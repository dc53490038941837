# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A goal's copies through the scene's contact, in exact mode: the planes, each copy alone.

The copies of a goal's body (:mod:`~rigid_sim.core.goal_copies`) are rows of one state
stepped together. In a scene whose contact is in exact mode they meet the ground planes as
the world's bodies do: a step advances every row, :class:`~rigid_sim.core.contact.exact.
ExactSteps` finds the impacts within it (the root of the least gap) and strikes them where
they happen, and the velocity-level stage resolves what the step ended at (resting
contact), as ``World.step`` does. In exact mode the pose at the goal's time is a smooth
function of the unknowns across an impact (the impact's moment moves with them: the
saltation matrix), so Newton's forward differences go through it.

Each copy has its own stage, restricted to its group's rows
(:meth:`~rigid_sim.core.contact.Contact.restricted`): copies are independent rollouts and
never collide with each other, nor with the world's other bodies. So the flight a goal
plans meets the planes (and the bodies of its group); :func:`~rigid_sim.core.goal_flight.
fly_world`, which flies the whole world, has the final word.

The first impact of any copy splits the step of all: every row is integrated to its
moment and on from there. A row is then the world's flight to the integrator's error, not
to the bit (to round-off where the flow is exact, as under gravity alone).
"""
import numpy as np

from rigid_sim.core.contact.exact import ExactSteps
from rigid_sim.core.goal_copies import spoiled
from rigid_sim.core.state import Model


class CopiesContact:
    """The contact of every copy, each on its own rows, as :class:`ExactSteps` calls it.

    Parameters
    ----------
    contact : rigid_sim.core.contact.Contact
        The world's stage (exact mode).
    copies : rigid_sim.core.goal_copies.Copies
    """

    def __init__(self, contact, copies):
        self.width = copies.width
        self.stages = [contact.restricted(copies.rows) for _ in range(copies.copies)]
        # The group's model: every copy's rows hold the same numbers.
        self.model = Model(*(np.ascontiguousarray(a[:self.width]) for a in copies.bodies.model))
        self._struck = [0] * copies.copies

    def _blocks(self, y):
        """Each copy's rows of ``y``: views, written in place by the stages."""
        return [y[k * self.width:(k + 1) * self.width] for k in range(len(self.stages))]

    def struck(self, start, end, model):
        """How many pairs the step from ``start`` to ``end`` struck, all copies together."""
        self._struck = [stage.struck(a, b, self.model) for stage, a, b
                        in zip(self.stages, self._blocks(start), self._blocks(end))]
        return sum(self._struck)

    def least_gap(self, y, struck):
        """Return the least gap at ``y`` of the pairs each copy's last :meth:`struck` listed, m."""
        return min(stage.least_gap(block, count) for stage, block, count
                   in zip(self.stages, self._blocks(y), self._struck) if count)

    def strike(self, y, model):
        """Strike the impacts of every copy at ``y`` in place; how many contacts there were."""
        return sum(stage.strike(block, self.model)
                   for stage, block in zip(self.stages, self._blocks(y)))

    def resolve(self, y, h, model):
        """Run the velocity-level stage of every copy at the end ``y`` of a step of ``h`` s."""
        return sum(stage.resolve(block, h, self.model)
                   for stage, block in zip(self.stages, self._blocks(y)))

    def forget(self):
        """Drop every copy's warm start: a new flight starts from none."""
        for stage in self.stages:
            stage.forget()


class _Substeps:
    """What :class:`ExactSteps` reads of the step controller's diagnostics."""

    substeps = 1


class FixedSteps:
    """The step controller's part :class:`ExactSteps` calls: steps of fixed substeps.

    A goal's copies take the substeps the flight planned (the world's guard has the final
    word in ``fly_world``), so ``step`` is the integrator's ``advance`` and nothing else.
    """

    def __init__(self, integrator):
        self.integrator = integrator
        self.diagnostics = _Substeps()
        self.failed = False   # whether a step since the caller last cleared it spoiled rows

    def step(self, y, into, time, dt, effects, version):
        """``into`` = ``y`` advanced by ``dt``; failed rows NaN."""
        into[...] = y
        if self.integrator.advance(into, time, dt, self.diagnostics.substeps, effects):
            spoiled(into)
            self.failed = True
        return into

    def state_changed(self):
        """Nothing is carried from one step to the next: every step starts afresh."""


class ContactSteps:
    """Steps of a goal's copies that strike their impacts and resolve their contacts.

    Parameters
    ----------
    contact : rigid_sim.core.contact.Contact
        The world's stage, in exact mode.
    copies : rigid_sim.core.goal_copies.Copies
    """

    def __init__(self, contact, copies):
        self.copies = copies
        self.contact = CopiesContact(contact, copies)
        self.exact = ExactSteps(self.contact, copies.width * copies.copies)
        self.control = FixedSteps(copies.integrator)
        self._spare = None
        self._parking = None

    def begin(self, parking):
        """Start a new flight: no copy's warm start is from another flight.

        ``parking`` (R, 13): the group's rows as the world has them, where a copy that
        failed waits (:meth:`advance`).
        """
        self.contact.forget()
        self._parking = parking

    def advance(self, y, time, steps, dt, substeps):
        """Advance ``y`` in place by ``steps`` steps of ``dt``, ``substeps`` pieces each.

        A copy whose rows failed (NaN) is parked at the group's start while the others
        fly on, and is NaN again at the end: the root finder integrates every row at once
        and gives up on a state with a failed row, which would lose the others' impacts.
        """
        if self._spare is None or self._spare.shape != y.shape:
            self._spare = np.empty_like(y)
        self.control.diagnostics.substeps = substeps
        effects = self.copies.effect_parameters()
        state, spare = y, self._spare
        failed = self._park(state)
        for k in range(steps):
            stepped = self.exact.step(self.control, None, state, spare, time + k * dt, dt,
                                      effects, 0)
            self.contact.resolve(stepped, dt, None)
            state, spare = stepped, state
            if self.control.failed:   # only a step of the integrator makes rows NaN
                self.control.failed = False
                failed |= self._park(state)
        if state is not y:
            y[...] = state
        y[failed] = np.nan

    def _park(self, y):
        """Rows (N,) bool of the copies in ``y`` that failed, set to the group's start."""
        width = self.contact.width
        bad = np.repeat((~np.isfinite(y).all(axis=1)).reshape(-1, width).any(axis=1), width)
        if bad.any():
            y[bad] = np.tile(self._parking, (int(bad.sum()) // width, 1))
        return bad
