# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The compiled contact stage: detect, solve, correct, in one call after a World step.

Detection reads the state the integrator's step ended at: every shape against every plane,
then the broad phase's pairs through the narrow phase. The contacts are sorted by key, so
their order (and the solve's floating-point operations) depend on the state alone, never on
the order detection found them in; the same run gives the same bits. The solve
(:mod:`~rigid_sim.core.contact.solver`) changes the momenta; the positions move by what
friction would have moved them in the step, then by the split-impulse correction.
"""
import math
from typing import NamedTuple

from numba.extending import overload
import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.contact import capsule, convex, cylinder, narrow
from rigid_sim.core.contact.broad import overlapping_pairs
from rigid_sim.core.contact.kinds import ShapeKinds
from rigid_sim.core.contact.narrow import BOX, CAPSULE, CYLINDER, SPHERE
from rigid_sim.core.contact.solver import (
    coupling, friction_row, impulse_sums, MOMENT, normal_row, relative_velocity,
    store_jacobians, tangents, TURN, warm_start, world_inverse_inertia)

# A solve stops at the sweep whose largest change of an impulse is at most this fraction of
# the largest impulse: further sweeps would change the velocities by round-off only.
CONVERGED = 1e-12


class ContactParameters(NamedTuple):
    """What the compiled stage reads: the scene's contact settings and the bodies' shapes."""

    planes: np.ndarray     # (P, 4): unit normal (world) and offset (m): n . x = offset
    kind: np.ndarray       # (N,) int: 0 none, SPHERE, BOX, CAPSULE, CYLINDER
    size: np.ndarray       # (N, 3) m: a sphere's radius in column 0; a box's half extents;
    # a capsule's or cylinder's radius and half length (along body z)
    offset: np.ndarray     # (N, 3) m, shape centre from the centre of mass, body axes
    friction: float        # Coulomb coefficient mu
    restitution: float     # Newton's e
    resting_speed: float   # m/s: slower approaches do not bounce
    compliance: float      # m/N: 0 rigid
    iterations: int        # Gauss-Seidel sweeps, for the impulses and for the positions
    margin: float          # m: features closer than this are contacts
    exact: bool            # impacts are struck where they happen (mode: exact), not here
    shapes: ShapeKinds     # the kinds in ``kind``: the stage is compiled for these alone


class ContactWork(NamedTuple):
    """Scratch and memory of the stage; C contacts and M pairs of room, grown as needed."""

    low: np.ndarray        # (N, 3) bounding box, m
    high: np.ndarray       # (N, 3)
    centre: np.ndarray     # (N, 3) shape centre, world, m
    rotation: np.ndarray   # (N, 3, 3) body-to-world rotation
    active: np.ndarray     # (N,) bool: has a collision shape
    inertia: np.ndarray    # (N, 3, 3) world inverse inertia, 1/(kg m^2)
    velocity: np.ndarray   # (N, 6) linear and angular velocity
    impulse: np.ndarray    # (N, 9) the solve's linear and angular impulse, N s, N m s;
    # then friction's linear impulse alone
    pseudo: np.ndarray     # (N, 6) position-correction velocities
    pairs: np.ndarray      # (M, 2) int
    contacts: narrow.Contacts
    order: np.ndarray      # (C,) int: the contacts by key
    rows: np.ndarray       # (C, ROW) solver constants, in key order
    body: np.ndarray       # (C, 2) int bodies, in key order
    lam: np.ndarray        # (C, 3) normal and tangential impulse, N s, in key order
    push: np.ndarray       # (C, 1) position-correction impulse
    last_key: np.ndarray   # (C,) int: the last step's keys, sorted
    last_lam: np.ndarray   # (C, 3) and their impulses
    last_count: np.ndarray  # (1,) int
    struck: np.ndarray     # (C, 2) int: pairs struck within a step (mode: exact)
    clip: np.ndarray       # (2, 8, 3): a box-box face patch's polygon and its next cut
    detected: np.ndarray   # (N, 13) in exact mode, else (0, 13): the state struck_pairs
    # left its detection of in this scratch, which contact_step then reads (see reuse)
    reuse: np.ndarray      # (3,) int: 1 while that detection is what the scratch holds, its
    # contacts and pairs
    convex: convex.ConvexScratch   # GJK's and EPA's (empty without cylinders)


@helper
def _shapes(y, model, parameters, work):
    """Each body's shape centre, rotation, inverse world inertia and bounding box."""
    for i in range(y.shape[0]):
        x, q, p, big_l = kin.body_state(y, i)
        r = kin.matrix(q)
        inertia = world_inverse_inertia(r, kin.entries(model.inertia_inv, i))
        for k in range(9):
            work.rotation[i, k // 3, k % 3] = r[k]
            work.inertia[i, k // 3, k % 3] = inertia[k]
        kin.store(work.velocity, i, 0, kin.scaled(model.inverse_mass[i], p))
        kin.store(work.velocity, i, 3, kin.rotate(inertia, big_l))
        for k in range(6):
            work.pseudo[i, k] = 0.0
        centre = kin.add(x, kin.rotate(r, kin.vector(parameters.offset, i, 0)))
        kin.store(work.centre, i, 0, centre)
        kind = parameters.kind[i]
        work.active[i] = kind != 0
        for k in range(3):
            if kind == SPHERE:
                reach = parameters.size[i, 0]
            elif kind == CAPSULE:
                reach = abs(r[3 * k + 2]) * parameters.size[i, 1] + parameters.size[i, 0]
            elif kind == CYLINDER:   # the caps' discs reach r sqrt(1 - a_k^2) across
                along = r[3 * k + 2]
                reach = (abs(along) * parameters.size[i, 1]
                         + parameters.size[i, 0] * math.sqrt(max(0.0, 1.0 - along * along)))
            else:
                reach = (abs(r[3 * k]) * parameters.size[i, 0]
                         + abs(r[3 * k + 1]) * parameters.size[i, 1]
                         + abs(r[3 * k + 2]) * parameters.size[i, 2])
            reach += parameters.margin   # shapes closer than the margin are in a pair
            work.low[i, k] = centre[k] - reach
            work.high[i, k] = centre[k] + reach


def _plane_contacts(shapes, parameters, work, slots):
    """Every shape against every plane; returns the count of contacts (maybe above room).

    Compiled for the set of kinds ``shapes`` (:mod:`.kinds`): a kind not in it is pruned.
    """


@overload(_plane_contacts)
def _plane_contacts_for(shapes, parameters, work, slots):
    # Constants of the closure: numba prunes a branch on a false one before typing its callee.
    capsules, cylinders = CAPSULE in shapes.kinds, CYLINDER in shapes.kinds

    def plane_contacts(shapes, parameters, work, slots):
        count = 0
        contacts, planes, margin = work.contacts, parameters.planes, parameters.margin
        for i in range(work.centre.shape[0]):
            kind = parameters.kind[i]
            if kind == 0:
                continue
            centre = kin.vector(work.centre, i, 0)
            for p in range(planes.shape[0]):
                normal, offset = kin.vector(planes, p, 0), planes[p, 3]
                r, size = kin.entries(work.rotation, i), parameters.size
                if kind == SPHERE:
                    count = narrow.sphere_plane(contacts, count, i, -1 - p, slots, margin,
                                                centre, size[i, 0], normal, offset)
                elif kind == BOX:
                    count = narrow.box_plane(contacts, count, i, -1 - p, slots, margin, centre,
                                             r, kin.vector(size, i, 0), normal, offset)
                elif capsules and kind == CAPSULE:
                    count = capsule.capsule_plane(contacts, count, i, -1 - p, slots, margin,
                                                  centre, narrow.axis(r, 2), size[i, 1],
                                                  size[i, 0], normal, offset)
                elif cylinders:
                    count = cylinder.cylinder_plane(contacts, count, i, -1 - p, slots, margin,
                                                    centre, r, size[i, 1], size[i, 0], normal,
                                                    offset)
        return count
    return plane_contacts


def _pair(shapes, work, count, a, b, slots, margin, kind_a, size_a, ca, ra, kind_b, size_b, cb,
          rb, flip):
    """One pair's narrow phase, ``kind_a <= kind_b``; ``flip``: they were swapped for it.

    A swapped pair writes ``b`` first and its normals point the other way, as
    :func:`~rigid_sim.core.contact.narrow.emit` wants them from ``b`` to ``a``. Compiled for
    the set of kinds ``shapes`` (:mod:`.kinds`): the pairs of a kind not in it are pruned.
    """


@overload(_pair)
def _pair_for(shapes, work, count, a, b, slots, margin, kind_a, size_a, ca, ra, kind_b, size_b,
              cb, rb, flip):
    # Constants of the closure: numba prunes a branch on a false one before typing its callee.
    capsules, cylinders = CAPSULE in shapes.kinds, CYLINDER in shapes.kinds

    def pair(shapes, work, count, a, b, slots, margin, kind_a, size_a, ca, ra, kind_b, size_b,
             cb, rb, flip):
        contacts = work.contacts
        first, second = (b, a) if flip else (a, b)
        if kind_a == SPHERE and kind_b == SPHERE:
            return narrow.sphere_sphere(contacts, count, first, second, slots, margin, ca,
                                        size_a[0], cb, size_b[0])
        if kind_a == SPHERE and kind_b == BOX:
            return narrow.sphere_box(contacts, count, first, second, slots, margin, ca,
                                     size_a[0], cb, rb, size_b, flip)
        if kind_a == BOX and kind_b == BOX:
            return narrow.box_box(contacts, count, first, second, slots, margin, ca, ra,
                                  size_a, cb, rb, size_b, work.clip)
        if capsules and kind_b == CAPSULE:
            axis_b = narrow.axis(rb, 2)
            if kind_a == SPHERE:
                return capsule.capsule_sphere(contacts, count, first, second, slots, margin,
                                              cb, axis_b, size_b[1], size_b[0], ca, size_a[0],
                                              not flip)
            if kind_a == BOX:
                return capsule.capsule_box(contacts, count, first, second, slots, margin, cb,
                                           axis_b, size_b[1], size_b[0], ca, ra, size_a,
                                           not flip)
            return capsule.capsule_capsule(contacts, count, first, second, slots, margin, ca,
                                           narrow.axis(ra, 2), size_a[1], size_a[0], cb,
                                           axis_b, size_b[1], size_b[0])
        if not cylinders:   # every pair of the kinds in the set was met above
            return count
        if kind_a == SPHERE:
            return cylinder.cylinder_sphere(contacts, count, first, second, slots, margin, cb,
                                            rb, size_b[1], size_b[0], ca, size_a[0], not flip)
        # A cylinder with a box, a capsule or a cylinder: by their support mappings.
        if flip:
            return convex.convex_pair(contacts, count, first, second, slots, margin, kind_b,
                                      size_b, cb, rb, kind_a, size_a, ca, ra, work.convex)
        return convex.convex_pair(contacts, count, first, second, slots, margin, kind_a,
                                  size_a, ca, ra, kind_b, size_b, cb, rb, work.convex)
    return pair


@helper
def _pair_contacts(parameters, work, pairs, count, slots):
    """Run the narrow phase of each of the first ``pairs`` pairs, after ``count`` contacts."""
    kind, size = parameters.kind, parameters.size
    margin, shapes = parameters.margin, parameters.shapes
    for k in range(pairs):
        a, b = work.pairs[k, 0], work.pairs[k, 1]
        ca, cb = kin.vector(work.centre, a, 0), kin.vector(work.centre, b, 0)
        ra, rb = kin.entries(work.rotation, a), kin.entries(work.rotation, b)
        sa, sb = kin.vector(size, a, 0), kin.vector(size, b, 0)
        if kind[a] <= kind[b]:
            count = _pair(shapes, work, count, a, b, slots, margin, kind[a], sa, ca, ra,
                          kind[b], sb, cb, rb, False)
        else:
            count = _pair(shapes, work, count, b, a, slots, margin, kind[b], sb, cb, rb,
                          kind[a], sa, ca, ra, True)
    return count


@helper
def _last_row(work, key):
    """Find the last step's row of the contact with ``key`` (-1: none), by binary search."""
    low, high = 0, work.last_count[0]
    while low < high:
        middle = (low + high) // 2
        if work.last_key[middle] < key:
            low = middle + 1
        else:
            high = middle
    if low < work.last_count[0] and work.last_key[low] == key:
        return low
    return -1


@helper
def contact_row(y, model, parameters, work, s, c, softness):
    """Contact ``c``'s constants into row ``s``: arms, normal, tangents, masses.

    ``softness`` is the compliance over the step squared (0 at an instant). Returns the
    contact's approach speed (negative: closing), m/s.
    """
    contacts, rows, inertia = work.contacts, work.rows, work.inertia
    a, b = contacts.body[c, 0], contacts.body[c, 1]
    work.body[s, 0], work.body[s, 1] = a, b
    point, n = kin.vector(contacts.point, c, 0), kin.vector(contacts.normal, c, 0)
    arm_a = kin.plus_scaled(point, -1.0, kin.vector(y, a, 0))
    arm_b = kin.plus_scaled(point, -1.0, kin.vector(y, b, 0)) if b >= 0 else arm_a
    t1, t2 = tangents(n)
    for k, v in enumerate((arm_a, arm_b, n, t1, t2)):
        kin.store(rows, s, 3 * k, v)
    for k, u in enumerate((n, t1, t2)):
        store_jacobians(rows, s, inertia, a, b, arm_a, arm_b, u, MOMENT + 6 * k, TURN + 6 * k)
    m = model.inverse_mass
    k11 = coupling(m, inertia, a, b, arm_a, arm_b, t1, t1)
    k12 = coupling(m, inertia, a, b, arm_a, arm_b, t1, t2)
    k22 = coupling(m, inertia, a, b, arm_a, arm_b, t2, t2)
    # The largest eigenvalue of the 2x2 tangential mobility (friction_row says why).
    big = 0.5 * (k11 + k22) + math.sqrt(0.25 * (k11 - k22) ** 2 + k12 * k12)
    rows[s, 15] = 1.0 / big
    kn = coupling(m, inertia, a, b, arm_a, arm_b, n, n)
    rows[s, 18] = 1.0 / (kn + softness)
    rows[s, 22] = 1.0 / kn
    return kin.dot(n, relative_velocity(work.velocity, a, b, arm_a, arm_b))


@helper
def _set_up(y, model, parameters, work, count, h):
    """Each contact's row of constants, in key order, and its warm-started impulse."""
    contacts, rows = work.contacts, work.rows
    m = model.inverse_mass
    for s in range(count):
        c = work.order[s]
        approach = contact_row(y, model, parameters, work, s, c,
                               parameters.compliance / (h * h))
        distance = contacts.distance[c]
        # A gap may close within the next step, no more (a speculative contact); an approach
        # faster than the resting speed that would close it bounces now, at most the margin
        # early. In exact mode such a gap is left open: the next step strikes its impact
        # where it happens (rigid_sim.core.contact.exact).
        closing = -distance / h if distance > 0.0 else 0.0
        fast = approach < -parameters.resting_speed
        if parameters.exact and fast and distance > 0.0:
            rows[s, 19] = -math.inf   # no impulse: a free flight
        else:
            bounces = fast and approach < closing
            rows[s, 19] = -parameters.restitution * approach if bounces else closing
        rows[s, 20] = approach
        rows[s, 21] = distance
        last = _last_row(work, contacts.key[c])
        for k in range(3):
            work.lam[s, k] = work.last_lam[last, k] if last >= 0 else 0.0
        warm_start(rows, s, work.velocity, m, work.body, work.lam)


@helper
def solve_impulses(model, parameters, work, count, softness):
    """Gauss-Seidel sweeps of the normal impulses, then of normal and friction together.

    ``softness`` is the compliance over the step squared (0 at an instant).
    """
    rows, m = work.rows, model.inverse_mass
    # Sweeps of the normal impulses alone first: friction then starts from the weights
    # the contacts carry, not from the rotations a first sweep's uneven pushes make. Each
    # solve stops at the sweep that changes no impulse by more than CONVERGED of the
    # largest: contacts that do not interact (balls on a floor) take one sweep.
    for _ in range(parameters.iterations):
        change, largest = 0.0, 0.0
        for s in range(count):
            change = max(change, normal_row(rows, s, work.velocity, m, softness, work.body,
                                            work.lam, rows[s, 19]))
            largest = max(largest, work.lam[s, 0])
        if change <= CONVERGED * largest:
            break
    for _ in range(parameters.iterations):
        change, largest = 0.0, 0.0
        for s in range(count):
            change = max(change, normal_row(rows, s, work.velocity, m, softness, work.body,
                                            work.lam, rows[s, 19]))
            change = max(change, friction_row(rows, s, work.velocity, m, parameters.friction,
                                              work.body, work.lam))
            largest = max(largest, work.lam[s, 0])
        if change <= CONVERGED * largest:
            break
    impulse_sums(rows, work.body, work.lam, count, work.impulse)


@helper
def _solve(model, parameters, work, count, h):
    """Gauss-Seidel sweeps of the impulses, then of the position correction."""
    rows, m = work.rows, model.inverse_mass
    solve_impulses(model, parameters, work, count, parameters.compliance / (h * h))
    # The penetration is removed within the step.
    for s in range(count):
        rows[s, 23] = -rows[s, 21] / h
        rows[s, 18] = rows[s, 22]   # the correction is rigid
        work.push[s, 0] = 0.0
    for _ in range(parameters.iterations):
        change, largest = 0.0, 0.0
        for s in range(count):
            change = max(change, normal_row(rows, s, work.pseudo, m, 0.0, work.body, work.push,
                                            rows[s, 23]))
            largest = max(largest, work.push[s, 0])
        if change <= CONVERGED * largest:
            break


@helper
def _move(y, model, work, h):
    """Add the impulses to the momenta and move the touched bodies' positions."""
    for i in range(y.shape[0]):
        touched = False
        for k in range(6):
            touched = touched or work.impulse[i, k] != 0.0 or work.pseudo[i, k] != 0.0
        if not touched:
            continue
        x, q, p, big_l = kin.body_state(y, i)
        sliding = kin.vector(work.impulse, i, 6)
        shift = kin.plus_scaled(kin.scaled(0.5 * h * model.inverse_mass[i], sliding), h,
                                kin.vector(work.pseudo, i, 0))
        turn = kin.scaled(h, kin.vector(work.pseudo, i, 3))
        q = kin.normalize(kin.multiply(kin.exp_map(turn), q))
        kin.store_body(y, i, kin.add(x, shift), q, kin.add(p, kin.vector(work.impulse, i, 0)),
                       kin.add(big_l, kin.vector(work.impulse, i, 3)))


@helper
def _remember(work, count):
    """Keep this step's keys and impulses, in key order, for the next step's warm start."""
    for s in range(count):
        work.last_key[s] = work.contacts.key[work.order[s]]
        for k in range(3):
            work.last_lam[s, k] = work.lam[s, k]
    work.last_count[0] = count


@helper
def detect(y, model, parameters, work):
    """Every contact of ``y`` closer than the margin, into ``work.contacts``, unsorted.

    Returns ``(contacts, pairs)`` found; when either is above the room of ``work`` the
    contacts were not all written.
    """
    slots = y.shape[0] + parameters.planes.shape[0]
    work.reuse[0] = 0   # the scratch is being overwritten: what it held is gone
    _shapes(y, model, parameters, work)
    count = _plane_contacts(parameters.shapes, parameters, work, slots)
    pairs = overlapping_pairs(work.low, work.high, work.active, work.pairs)
    if pairs > work.pairs.shape[0] or count > work.order.shape[0]:
        return count, pairs
    return _pair_contacts(parameters, work, pairs, count, slots), pairs


@helper
def keep_detection(y, work, count, pairs):
    """Say the scratch holds the detection of ``y`` (exact mode): ``count`` contacts, ``pairs``.

    Exact mode's check of a step (``impact.struck_pairs``) detects the state the step ended
    at; when nothing was struck, the velocity-level stage runs on that same state next and
    reads this detection instead of making it again.
    """
    work.detected[...] = y
    work.reuse[0], work.reuse[1], work.reuse[2] = 1, count, pairs


@helper
def _kept_detection(y, work):
    """Whether the scratch holds the detection of ``y``: the state kept, to the bit."""
    if work.reuse[0] == 0 or work.detected.shape != y.shape:
        return False
    for i in range(y.shape[0]):
        for k in range(y.shape[1]):
            a, b = y[i, k], work.detected[i, k]
            if a != b or math.copysign(1.0, a) != math.copysign(1.0, b):
                return False
    return True


@helper
def sort_by_key(work, count):
    """``work.order``: the first ``count`` contacts by key (a stable sort)."""
    order = np.argsort(work.contacts.key[:count], kind='mergesort')
    for s in range(count):
        work.order[s] = order[s]


@kernel
def contact_step(y, model, parameters, h, work):
    """Resolve the contacts of the state ``y`` (N, 13) a step of ``h`` s ended at, in place.

    Returns ``(contacts, pairs)``: how many of each were found. When either is above the
    room of ``work`` nothing was changed: the caller grows ``work`` and calls again.
    """
    if _kept_detection(y, work):
        count, pairs = work.reuse[1], work.reuse[2]
        work.reuse[0] = 0   # read once: the solve below changes the scratch's velocities
    else:
        count, pairs = detect(y, model, parameters, work)
    if pairs > work.pairs.shape[0] or count > work.order.shape[0]:
        return count, pairs
    sort_by_key(work, count)
    _set_up(y, model, parameters, work, count, h)
    _solve(model, parameters, work, count, h)
    _move(y, model, work, h)
    _remember(work, count)
    return count, pairs
