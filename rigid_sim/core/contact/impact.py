# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Exact mode's compiled parts: the pairs a step struck, their gap, an impact's impulses.

:mod:`~rigid_sim.core.contact.exact` steps a world to the moment an impact happens and
strikes it there. It asks three things of compiled code: which pairs the step struck
(:func:`struck_pairs`), the least gap of those pairs at a state (:func:`least_gap`, the
function whose root is the impact) and the impulses of the impact (:func:`strike`).
"""
import math

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.contact.narrow import box_box_gap, sphere_box_contact
from rigid_sim.core.contact.solver import relative_velocity
from rigid_sim.core.contact.stage import (
    contact_row, detect, keep_detection, SPHERE, solve_impulses, sort_by_key)


@helper
def _pose(y, parameters, i):
    """Body ``i``'s shape centre (world, m) and rotation (row-major 9-tuple)."""
    r = kin.matrix(kin.orientation(y, i))
    return kin.add(kin.vector(y, i, 0), kin.rotate(r, kin.vector(parameters.offset, i, 0))), r


@helper
def _plane_gap(y, parameters, a, p):
    """Signed distance of body ``a``'s shape from plane ``p``: its lowest point's, m."""
    centre, r = _pose(y, parameters, a)
    normal, offset = kin.vector(parameters.planes, p, 0), parameters.planes[p, 3]
    if parameters.kind[a] == SPHERE:
        return kin.dot(normal, centre) - offset - parameters.size[a, 0]
    half = kin.vector(parameters.size, a, 0)
    gap = math.inf
    for corner in range(8):
        local = (half[0] if corner & 1 else -half[0], half[1] if corner & 2 else -half[1],
                 half[2] if corner & 4 else -half[2])
        gap = min(gap, kin.dot(normal, kin.add(centre, kin.rotate(r, local))) - offset)
    return gap


@helper
def pair_gap(y, parameters, a, b):
    """Signed gap of body ``a`` and body ``b`` (``b < 0``: plane ``-1 - b``), m.

    Negative when they overlap, zero when they touch: continuous in the state, so a root
    finder brackets the moment of an impact by it.
    """
    if b < 0:
        return _plane_gap(y, parameters, a, -1 - b)
    kind, size = parameters.kind, parameters.size
    ca, ra = _pose(y, parameters, a)
    cb, rb = _pose(y, parameters, b)
    if kind[a] == SPHERE and kind[b] == SPHERE:
        delta = kin.plus_scaled(ca, -1.0, cb)
        return math.sqrt(kin.dot(delta, delta)) - size[a, 0] - size[b, 0]
    if kind[a] == SPHERE:
        return sphere_box_contact(ca, size[a, 0], cb, rb, kin.vector(size, b, 0))[0]
    if kind[b] == SPHERE:
        return sphere_box_contact(cb, size[b, 0], ca, ra, kin.vector(size, a, 0))[0]
    return box_box_gap(ca, ra, kin.vector(size, a, 0), cb, rb, kin.vector(size, b, 0))


@kernel
def least_gap(y, parameters, struck, count):
    """Return the least :func:`pair_gap` of the first ``count`` pairs of ``struck`` at ``y``, m."""
    gap = math.inf
    for k in range(count):
        gap = min(gap, pair_gap(y, parameters, struck[k, 0], struck[k, 1]))
    return gap


@helper
def _approach(y, work, c):
    """Return the normal speed of detected contact ``c`` (negative: closing), m/s."""
    contacts = work.contacts
    a, b = contacts.body[c, 0], contacts.body[c, 1]
    point = kin.vector(contacts.point, c, 0)
    arm_a = kin.plus_scaled(point, -1.0, kin.vector(y, a, 0))
    arm_b = kin.plus_scaled(point, -1.0, kin.vector(y, b, 0)) if b >= 0 else arm_a
    return kin.dot(kin.vector(contacts.normal, c, 0),
                   relative_velocity(work.velocity, a, b, arm_a, arm_b))


@helper
def _resting(y, parameters, work, count, a, b):
    """Whether pair (a, b) touches at ``y`` (detected) without closing fast at any point."""
    contacts = work.contacts
    for c in range(count):
        if contacts.body[c, 0] == a and contacts.body[c, 1] == b \
                and _approach(y, work, c) >= -parameters.resting_speed:
            return True
    return False


@kernel
def struck_pairs(start, end, model, parameters, work):
    """List the pairs a step from ``start`` to ``end`` struck in ``work.struck``.

    A pair is struck when at ``end`` a point of it overlaps while closing faster than the
    resting speed, and at ``start`` it was apart (its :func:`pair_gap` positive) and not
    resting on each other (touching, closing slower than the resting speed: the
    velocity-level stage holds those). Returns ``(contacts, pairs, struck)``; when either
    of the first two is above the room of ``work``, the caller grows it and calls again.
    """
    room = work.order.shape[0]
    count, pairs = detect(end, model, parameters, work)
    if pairs > work.pairs.shape[0] or count > room:
        return count, pairs, 0
    struck = 0
    for c in range(count):
        if work.contacts.distance[c] < 0.0 \
                and _approach(end, work, c) < -parameters.resting_speed:
            a, b = work.contacts.body[c, 0], work.contacts.body[c, 1]
            known = False
            for k in range(struck):
                known = known or (work.struck[k, 0] == a and work.struck[k, 1] == b)
            if not known:
                work.struck[struck, 0], work.struck[struck, 1] = a, b
                struck += 1
    if struck == 0:
        keep_detection(end, work, count, pairs)   # the stage runs on ``end`` next
        return count, pairs, 0
    # Round-off can make the gap's sign and the contacts' disagree: both ends are checked
    # by the gap, which the root finder reads.
    found = struck
    count, pairs = detect(start, model, parameters, work)
    if pairs > work.pairs.shape[0] or count > room:
        return count, pairs, 0
    struck = 0
    for k in range(found):
        a, b = work.struck[k, 0], work.struck[k, 1]
        if pair_gap(start, parameters, a, b) > 0.0 and pair_gap(end, parameters, a, b) < 0.0 \
                and not _resting(start, parameters, work, count, a, b):
            work.struck[struck, 0], work.struck[struck, 1] = a, b
            struck += 1
    return count, pairs, struck


@kernel
def strike(y, model, parameters, work):
    """Apply the impulses of an impact at the state ``y`` (N, 13), in place: momenta only.

    Every contact closer than ``parameters.margin`` (exact mode's impact margin) is solved
    together, at an instant: rigid, from zero impulses (the warm start belongs to the
    velocity-level stage and is kept for it). A contact closing faster than the resting
    speed leaves at ``e`` times its approach (Newton), a slower one stops closing;
    friction as the velocity-level stage has it. Returns ``(contacts, pairs)`` found, as
    :func:`~rigid_sim.core.contact.stage.contact_step` does.
    """
    count, pairs = detect(y, model, parameters, work)
    if pairs > work.pairs.shape[0] or count > work.order.shape[0]:
        return count, pairs
    sort_by_key(work, count)
    # First the resting contacts alone: they held their bodies through the piece the
    # impact ends, and the step controller's integration let those sink under gravity,
    # so they stop them now (the velocity-level stage would at the step's end). Then an
    # impact meets a body at rest, as it was: a ball onto a box on the ground leaves at
    # e times its own speed, not e times its speed less the box's sinking.
    for s in range(count):
        approach = contact_row(y, model, parameters, work, s, work.order[s], 0.0)
        work.rows[s, 19] = -math.inf if approach < -parameters.resting_speed else 0.0
        for k in range(3):
            work.lam[s, k] = 0.0
    solve_impulses(model, parameters, work, count, 0.0)
    for s in range(count):
        a, b = work.body[s, 0], work.body[s, 1]
        approach = kin.dot(kin.vector(work.rows, s, 6), relative_velocity(
            work.velocity, a, b, kin.vector(work.rows, s, 0), kin.vector(work.rows, s, 3)))
        bounces = approach < -parameters.resting_speed
        work.rows[s, 19] = -parameters.restitution * approach if bounces else 0.0
    solve_impulses(model, parameters, work, count, 0.0)
    for i in range(y.shape[0]):
        touched = False
        for k in range(6):
            touched = touched or work.impulse[i, k] != 0.0
        if not touched:
            continue
        x, q, p, big_l = kin.body_state(y, i)
        kin.store_body(y, i, x, q, kin.add(p, kin.vector(work.impulse, i, 0)),
                       kin.add(big_l, kin.vector(work.impulse, i, 3)))
    return count, pairs
