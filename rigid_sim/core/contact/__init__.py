# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Contact: bodies rest on, slide along, roll on and bounce off planes and each other.

Contact is listed under the scene's ``effects:`` as ``contact:``, but it is not a force of
the state: it is a velocity-level stage the World runs after each step of its integrator
(:meth:`rigid_sim.core.world.World.step`), one compiled call
(:func:`~rigid_sim.core.contact.stage.contact_step`) that detects the contacts of the
state the step ended at and changes momenta and positions by impulses. A scene without
``contact:`` builds no :class:`Contact`, and its worlds step as they always did.

One module per concern: :mod:`~rigid_sim.core.contact.broad` (sort and sweep),
:mod:`~rigid_sim.core.contact.narrow` (the sphere and box pairs),
:mod:`~rigid_sim.core.contact.capsule` and :mod:`~rigid_sim.core.contact.cylinder` (theirs),
:mod:`~rigid_sim.core.contact.solver` (the impulses), :mod:`~rigid_sim.core.contact.stage`
(the compiled call that runs them), :mod:`~rigid_sim.core.contact.kinds` (the set of shape
kinds the stage is compiled for), :mod:`~rigid_sim.core.contact.shapes` (each body's
collision shape from the scene). In exact mode (``mode: exact``)
:mod:`~rigid_sim.core.contact.exact` strikes impacts at the moment they happen, with the
compiled parts of :mod:`~rigid_sim.core.contact.impact`.
"""
import copy

import numpy as np

from rigid_sim.core.contact.convex import convex_scratch
from rigid_sim.core.contact.exact import ExactSteps
from rigid_sim.core.contact.impact import least_gap, strike, struck_pairs
from rigid_sim.core.contact.kinds import ShapeKinds
from rigid_sim.core.contact.narrow import Contacts, CYLINDER
from rigid_sim.core.contact.shapes import shape_arrays
from rigid_sim.core.contact.solver import ROW
from rigid_sim.core.contact.stage import ContactParameters, ContactWork, contact_step
from rigid_sim.core.scene_fields import (
    choice, count, list_of, Mistake, non_negative, number, REQUIRED, table, vector)
from rigid_sim.core.dispatch import CompiledCall

# A plane's normal shorter than this has no direction to normalise.
MIN_NORMAL = 1e-9
# Gauss-Seidel sweeps at most: each costs a pass over the contacts, twice (impulses and
# positions), and a tick must stay bounded.
MAX_ITERATIONS = 1000
# Features closer than this are contacts, m: bodies that touch exactly stay touching when a
# step moves them together (a stack), and an impact is found at most this early.
MARGIN = 1e-5
# Features closer than this are struck together at an impact (exact mode), m: the root
# finder leaves the struck pair about 1e-14 m from touching, and a feature a margin away
# must meet its own impact later, not be struck early.
IMPACT_MARGIN = 1e-9
# Room for this many body-body contacts per body at first; more is made when a step needs it.
PAIR_ROOM = 8


def _planes(value, key):
    """Check the ground planes: a list of {normal, offset}, the normal made unit."""
    planes = list_of(table({'normal': (vector, REQUIRED), 'offset': (number, 0.0)}),
                     'planes')(value, key)
    rows = []
    for k, plane in enumerate(planes):
        length = float(np.linalg.norm(plane['normal']))
        if length < MIN_NORMAL:
            raise Mistake(f'{key}[{k}].normal', 'a plane normal must not be zero')
        rows.append(np.append(plane['normal'] / length, plane['offset']))
    return np.array(rows, dtype=float).reshape(len(rows), 4)


def _fraction(value, key):
    """Check a number in [0, 1] (restitution)."""
    value = non_negative(value, key)
    if value > 1.0:
        raise Mistake(key, f'must be at most 1 (1: elastic, 0: no bounce), got {value!r}')
    return value


def _iterations(value, key):
    value = count(value, key)
    if value > MAX_ITERATIONS:
        raise Mistake(key, f'must be at most {MAX_ITERATIONS}, got {value}')
    return value


SETTINGS = {
    'planes': (_planes, []),             # the ground: n . x = offset, bodies on the n side
    'friction': (non_negative, 0.5),     # Coulomb's mu
    'restitution': (_fraction, 0.0),     # Newton's e
    # m/s: an approach slower than this ends at rest instead of bouncing (no Zeno).
    'resting_speed': (non_negative, 0.2),
    'compliance': (non_negative, 0.0),   # m/N; 0: rigid
    'iterations': (_iterations, 30),     # Gauss-Seidel sweeps per step
    # velocity: impacts resolved where a step ends; exact: where they happen (root finding).
    'mode': (choice('velocity', 'exact'), 'velocity'),
}


class Contact:
    """The contact stage of one world: its settings, the bodies' shapes, its scratch.

    Parameters
    ----------
    bodies : RigidBodies
        The world's bodies (their centres of mass place the shapes).
    collision : sequence of dict
        Each body's collision shape in its body frame, as :mod:`.shapes` checks them.
    planes : (P, 4) float
        Unit normal and offset of each ground plane, world.
    friction, restitution, resting_speed, compliance, iterations, mode
        As :data:`SETTINGS` says.
    """

    name = 'contact'
    scene_fields = table(SETTINGS)

    def __init__(self, bodies, collision, planes, friction=0.5, restitution=0.0,
                 resting_speed=0.2, compliance=0.0, iterations=30, mode='velocity'):
        kind, size = shape_arrays(collision)
        self.parameters = ContactParameters(
            np.ascontiguousarray(planes, dtype=float).reshape(-1, 4), kind, size,
            np.ascontiguousarray(-bodies.com_in_body, dtype=float), float(friction),
            float(restitution), float(resting_speed), float(compliance), int(iterations),
            MARGIN, mode == 'exact', ShapeKinds(kind))
        n = bodies.count
        # Exact mode: the steps that strike impacts where they happen; None: velocity mode.
        self.exact = None
        if mode == 'exact':
            self.exact = ExactSteps(self, n)
            self._impact_parameters = self.parameters._replace(margin=IMPACT_MARGIN)
            self._struck = CompiledCall(struck_pairs)
            self._strike = CompiledCall(strike)
            self._gap = CompiledCall(least_gap)
        self._bodies = n
        self.work = self._room(n * (8 * len(self.parameters.planes) + PAIR_ROOM), n * PAIR_ROOM)
        self.count = 0   # contacts of the last step
        self._call = CompiledCall(contact_step)

    def _room(self, contacts, pairs, last=None):
        """Scratch for ``contacts`` contacts and ``pairs`` pairs; keeps ``last``'s memory."""
        n = self._bodies
        work = ContactWork(
            low=np.empty((n, 3)), high=np.empty((n, 3)), centre=np.empty((n, 3)),
            rotation=np.empty((n, 3, 3)), active=np.empty(n, dtype=np.bool_),
            inertia=np.empty((n, 3, 3)), velocity=np.empty((n, 6)), impulse=np.empty((n, 9)),
            pseudo=np.empty((n, 6)), pairs=np.empty((pairs, 2), dtype=np.int64),
            contacts=Contacts(np.empty((contacts, 2), dtype=np.int64),
                              np.empty(contacts, dtype=np.int64), np.empty((contacts, 3)),
                              np.empty((contacts, 3)), np.empty(contacts)),
            order=np.empty(contacts, dtype=np.int64), rows=np.empty((contacts, ROW)),
            body=np.empty((contacts, 2), dtype=np.int64), lam=np.empty((contacts, 3)),
            push=np.empty((contacts, 1)),
            last_key=np.empty(contacts, dtype=np.int64), last_lam=np.empty((contacts, 3)),
            last_count=np.zeros(1, dtype=np.int64),
            struck=np.empty((contacts, 2), dtype=np.int64), clip=np.empty((2, 8, 3)),
            convex=convex_scratch(CYLINDER in self.parameters.shapes.kinds),
            detected=np.empty((n if self.parameters.exact else 0, 13)),
            reuse=np.zeros(3, dtype=np.int64))
        if last is not None:
            kept = last.last_count[0]
            work.last_key[:kept] = last.last_key[:kept]
            work.last_lam[:kept] = last.last_lam[:kept]
            work.last_count[0] = kept
        return work

    def restricted(self, rows):
        """Return the stage of bodies ``rows`` (R,) alone: same planes and settings.

        Its own scratch and no warm start, and this stage's compiled code (its set of shape
        kinds holds theirs): a goal's copies of a body
        (:mod:`rigid_sim.core.goal_contact`) meet the planes and each other within their
        group, never another copy or a body left out.
        """
        part = copy.copy(self)
        keep = {'kind': self.parameters.kind[rows], 'size': self.parameters.size[rows],
                'offset': self.parameters.offset[rows]}
        part.parameters = self.parameters._replace(**{
            name: np.ascontiguousarray(value) for name, value in keep.items()})
        part._bodies = len(rows)
        part.work = part._room(len(rows) * (8 * len(self.parameters.planes) + PAIR_ROOM),
                               len(rows) * PAIR_ROOM)
        part.count = 0
        if self.exact is not None:
            part.exact = ExactSteps(part, len(rows))
            part._impact_parameters = part.parameters._replace(margin=IMPACT_MARGIN)
        return part

    def duplicate(self):
        """Return a stage that steps as this one would from here: its own scratch and memory."""
        twin = copy.copy(self)
        twin.work = self._room(self.work.order.shape[0], self.work.pairs.shape[0], self.work)
        if self.exact is not None:
            twin.exact = ExactSteps(twin, self._bodies)
        return twin

    def forget(self):
        """Drop the warm start: the next step solves from zero impulses (a reset)."""
        self.work.last_count[0] = 0
        self.work.reuse[0] = 0   # and detects again, whatever state it meets

    def resolve(self, y, h, model):
        """Resolve the contacts of ``y`` (N, 13), which a step of ``h`` s ended at, in place.

        Returns how many contacts there were (0: ``y`` is unchanged).
        """
        while True:
            found, pairs = self._call(y, model, self.parameters, h, self.work)
            if not self._grown(found, pairs):
                self.count = found
                return found

    def _grown(self, found, pairs):
        """Grow the scratch if ``found`` contacts or ``pairs`` pairs did not fit; whether."""
        room, pair_room = self.work.order.shape[0], self.work.pairs.shape[0]
        if found <= room and pairs <= pair_room:
            return False
        self.work = self._room(max(room, 2 * found), max(pair_room, 2 * pairs), self.work)
        return True

    def struck(self, start, end, model):
        """Count the pairs struck by a step between two states (exact mode).

        The step went from ``start`` to ``end``; the pairs are listed in ``work.struck``;
        :func:`~rigid_sim.core.contact.impact.struck_pairs` says which pairs are struck.
        """
        while True:
            found, pairs, struck = self._struck(start, end, model, self.parameters, self.work)
            if not self._grown(found, pairs):
                return struck

    def least_gap(self, y, struck):
        """Return the least gap at ``y`` of the first ``struck`` pairs of ``work.struck``, m."""
        return self._gap(y, self.parameters, self.work.struck, struck)

    def strike(self, y, model):
        """Strike the impacts of ``y`` in place (exact mode); how many contacts there were."""
        while True:
            found, pairs = self._strike(y, model, self._impact_parameters, self.work)
            if not self._grown(found, pairs):
                return found

    def probe(self, y, h, model):
        """Compile (or load) the stage by one call on a copy of ``y``; nothing is changed.

        The warm start, the scratch and the last step's contacts are kept as they were.
        """
        kept, count = self.work, self.count
        self.work = self._room(kept.order.shape[0], kept.pairs.shape[0], kept)
        try:
            probe = np.array(y, dtype=float)
            if self.exact is not None:
                self.struck(probe, probe, model)
                self.least_gap(probe, 0)
                self.strike(probe, model)
            self.resolve(probe, h, model)
        finally:
            self.work, self.count = kept, count

    def contacts(self):
        """Return the last step's contacts in key order: bodies (C, 2), points, normals, impulses.

        ``bodies[:, 1] < 0`` names plane ``-1 - b``; points (C, 3) m and normals (C, 3)
        world, the normal from the second body to the first; impulses (C, 3) N s, normal
        then the two tangential components.
        """
        work, c = self.work, self.count
        order = work.order[:c]
        return (work.body[:c].copy(), work.contacts.point[order],
                work.contacts.normal[order], work.lam[:c].copy())
