# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Velocity-level contact solver: sequential impulses (projected Gauss-Seidel), compiled.

Each contact has a normal impulse ``lambda_n >= 0`` and a tangential impulse
``lambda_t`` (2 components in the contact's tangent plane) inside the isotropic Coulomb
cone ``|lambda_t| <= mu lambda_n``: the tangential update is projected onto that disc, not
onto a pyramid, so friction has the same strength in every direction. The normal row
aims at Newton's restitution, ``v_n = -e v_n^-``, for an approach faster than the resting
speed, else at ``v_n = 0`` (so a body settles instead of bouncing ever smaller: no Zeno).
The solve starts from the impulses the same contacts (by key) had at the last step (warm
start), which lets a stack converge over steps rather than within one.

Friction acts as a constant force would over the step that just ended: the centres of
mass move by ``h/2`` times the change of velocity friction made (the trapezoidal rule,
exact for a slide's constant deceleration and for rolling). The orientations do not: the
same shift of the angles made a stack of boxes, whose friction couples hold each other,
grow a wobble and fall (measured: 10 boxes fell within 2 s; docs/contact.md). The normal
impulses change velocities only; the penetration the step left is removed by a second
solve, of pseudo-velocities that move the positions only (split impulse), so the
correction adds no energy and a body resting under gravity ends each step exactly on its
support.
"""
import math

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper

# The helpers a Gauss-Seidel sweep calls per contact are inlined into it: a call that passes
# arrays takes and drops a reference to each, which cost more than the row's arithmetic.


@helper
def world_inverse_inertia(r, inertia_inv):
    """``R I_body^-1 R^T`` (row-major 9-tuple) of the rotation ``r`` and body-axes inverse."""
    c0 = kin.rotate(r, kin.rotate(inertia_inv, (r[0], r[1], r[2])))
    c1 = kin.rotate(r, kin.rotate(inertia_inv, (r[3], r[4], r[5])))
    c2 = kin.rotate(r, kin.rotate(inertia_inv, (r[6], r[7], r[8])))
    return (c0[0], c1[0], c2[0], c0[1], c1[1], c2[1], c0[2], c1[2], c2[2])


@helper
def tangents(n):
    """Two unit vectors completing the unit normal ``n`` to a right-handed basis.

    From the world axis least along ``n``, so the basis depends on ``n`` alone.
    """
    if abs(n[0]) <= abs(n[1]) and abs(n[0]) <= abs(n[2]):
        e = (1.0, 0.0, 0.0)
    elif abs(n[1]) <= abs(n[2]):
        e = (0.0, 1.0, 0.0)
    else:
        e = (0.0, 0.0, 1.0)
    t1 = kin.cross(n, e)
    t1 = kin.scaled(1.0 / math.sqrt(kin.dot(t1, t1)), t1)
    return t1, kin.cross(n, t1)


@helper(inline='always')
def _mobility(inverse_mass, inv_inertia, i, arm, u, w):
    """``u . (dv + dw x arm)`` of body ``i`` per unit impulse along ``w`` at ``arm``."""
    turn = kin.rotate(kin.entries(inv_inertia, i), kin.cross(arm, w))
    return inverse_mass[i] * kin.dot(u, w) + kin.dot(kin.cross(arm, u), turn)


@helper(inline='always')
def coupling(inverse_mass, inv_inertia, a, b, arm_a, arm_b, u, w):
    """Relative velocity along ``u`` at the contact per unit impulse along ``w``, s/kg."""
    k = _mobility(inverse_mass, inv_inertia, a, arm_a, u, w)
    if b >= 0:
        k += _mobility(inverse_mass, inv_inertia, b, arm_b, u, w)
    return k


@helper(inline='always')
def relative_velocity(velocity, a, b, arm_a, arm_b):
    """Velocity of ``a``'s material point at the contact minus ``b``'s, world, m/s.

    ``velocity`` (N, 6) holds each body's linear and angular velocity.
    """
    v = kin.add(kin.vector(velocity, a, 0), kin.cross(kin.vector(velocity, a, 3), arm_a))
    if b >= 0:
        vb = kin.add(kin.vector(velocity, b, 0), kin.cross(kin.vector(velocity, b, 3), arm_b))
        v = kin.plus_scaled(v, -1.0, vb)
    return v


# Columns of a contact's row (``rows``, (C, ROW)) that a sweep reads. Per direction
# ``u`` (the normal, tangent 1, tangent 2): ``arm x u`` of body a then b (its angular
# Jacobian), and the inverse world inertia times it (the turn a unit impulse along ``u``
# gives each body). Made once per step in the stage's row set-up, so a row's update costs
# dot products and scaled adds, not the crosses and matrix products of the arms: those
# were most of a sweep (a stack of 10 boxes runs 600 sweeps a step).
NORMAL, TANGENT_1, TANGENT_2 = 6, 9, 12   # the unit directions, world
MOMENT = 24   # arm x u: a (3), then b (3), for the normal, tangent 1, tangent 2 in turn
TURN = 42     # I^-1 (arm x u) likewise
ROW = 60


@helper
def store_jacobians(rows, s, inv_inertia, a, b, arm_a, arm_b, u, moment, turn):
    """Write ``arm x u`` and ``I^-1 (arm x u)`` of bodies ``a`` and ``b`` (if any) into row ``s``.

    ``moment`` and ``turn`` are the first columns of each: a's three, then b's (zero for a
    plane, which no sweep reads).
    """
    for k, (i, arm) in enumerate(((a, arm_a), (b, arm_b))):
        m, t = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        if i >= 0:
            m = kin.cross(arm, u)
            t = kin.rotate(kin.entries(inv_inertia, i), m)
        kin.store(rows, s, moment + 3 * k, m)
        kin.store(rows, s, turn + 3 * k, t)


@helper(inline='always')
def _speed_along(rows, s, velocity, a, b, u, moment):
    """Relative velocity at contact ``s`` along its direction ``u``, by its row's Jacobian."""
    speed = (kin.dot(kin.vector(rows, s, u), kin.vector(velocity, a, 0))
             + kin.dot(kin.vector(rows, s, moment), kin.vector(velocity, a, 3)))
    if b >= 0:
        speed -= (kin.dot(kin.vector(rows, s, u), kin.vector(velocity, b, 0))
                  + kin.dot(kin.vector(rows, s, moment + 3), kin.vector(velocity, b, 3)))
    return speed


@helper(inline='always')
def _impel(velocity, inverse_mass, i, sign, j, turn):
    """Change body ``i``'s velocities by ``sign`` times the linear impulse ``j`` and ``turn``."""
    for k in range(3):
        velocity[i, k] += sign * inverse_mass[i] * j[k]
        velocity[i, 3 + k] += sign * turn[k]


@helper(inline='always')
def _along_row(rows, s, column, c_n, c_1, c_2):
    """``c_n u_n + c_1 u_1 + c_2 u_2``, the vectors ``u`` at ``column``, +6, +12 of row ``s``."""
    return kin.add(kin.scaled(c_n, kin.vector(rows, s, column)),
                   kin.add(kin.scaled(c_1, kin.vector(rows, s, column + 6)),
                           kin.scaled(c_2, kin.vector(rows, s, column + 12))))


@helper
def warm_start(rows, s, velocity, inverse_mass, body, lam):
    """Change the velocities by contact ``s``'s impulse ``lam[s]`` (normal, two tangential)."""
    j = kin.add(kin.scaled(lam[s, 0], kin.vector(rows, s, NORMAL)),
                kin.add(kin.scaled(lam[s, 1], kin.vector(rows, s, TANGENT_1)),
                        kin.scaled(lam[s, 2], kin.vector(rows, s, TANGENT_2))))
    for k, (i, sign) in enumerate(((body[s, 0], 1.0), (body[s, 1], -1.0))):
        if i >= 0:
            turn = _along_row(rows, s, TURN + 3 * k, lam[s, 0], lam[s, 1], lam[s, 2])
            _impel(velocity, inverse_mass, i, sign, j, turn)


@helper
def impulse_sums(rows, body, lam, count, impulse):
    """Each body's impulse (N, 9) from the first ``count`` contacts' impulses ``lam``.

    Linear and angular (about the centre of mass), then friction's linear impulse alone.
    Summed once from the solve's end impulses, where summing each sweep's changes (the
    same total) was a third of a sweep's memory traffic.
    """
    impulse[...] = 0.0
    for s in range(count):
        friction = kin.add(kin.scaled(lam[s, 1], kin.vector(rows, s, TANGENT_1)),
                           kin.scaled(lam[s, 2], kin.vector(rows, s, TANGENT_2)))
        j = kin.add(kin.scaled(lam[s, 0], kin.vector(rows, s, NORMAL)), friction)
        for k, (i, sign) in enumerate(((body[s, 0], 1.0), (body[s, 1], -1.0))):
            if i >= 0:
                moment = _along_row(rows, s, MOMENT + 3 * k, lam[s, 0], lam[s, 1], lam[s, 2])
                for c in range(3):
                    impulse[i, c] += sign * j[c]
                    impulse[i, 3 + c] += sign * moment[c]
                    impulse[i, 6 + c] += sign * friction[c]


@helper(inline='always')
def friction_row(rows, s, velocity, inverse_mass, mu, body, lam):
    """One Gauss-Seidel update of contact ``s``'s tangential impulse, kept in the cone.

    ``rows`` (C, ROW): arm a, arm b, normal, tangent 1, tangent 2, the tangential mass, two
    spare, the normal mass, the normal target, the approach speed, the distance, the rigid
    normal mass, the correction's target, then the Jacobians (:data:`MOMENT`, :data:`TURN`).
    Returns the largest change of a component, N s.
    """
    a, b = body[s, 0], body[s, 1]
    t1, t2 = kin.vector(rows, s, TANGENT_1), kin.vector(rows, s, TANGENT_2)
    v1 = _speed_along(rows, s, velocity, a, b, TANGENT_1, MOMENT + 6)
    v2 = _speed_along(rows, s, velocity, a, b, TANGENT_2, MOMENT + 12)
    # One step against the slip, of the largest mobility's inverse: it stops the slip along
    # that direction and under-steps the other, so sweeps converge; on the disc's edge the
    # result stays against the slip (maximal dissipation), where a 2x2 solve of an
    # anisotropic contact (a box's corner) would turn the friction aside and weaken a slide.
    l1 = lam[s, 1] - rows[s, 15] * v1
    l2 = lam[s, 2] - rows[s, 15] * v2
    bound = mu * lam[s, 0]
    size = math.sqrt(l1 * l1 + l2 * l2)
    if size > bound:   # onto the disc |lambda_t| <= mu lambda_n
        l1, l2 = l1 * (bound / size), l2 * (bound / size)
    d1, d2 = l1 - lam[s, 1], l2 - lam[s, 2]
    lam[s, 1], lam[s, 2] = l1, l2
    j = kin.add(kin.scaled(d1, t1), kin.scaled(d2, t2))
    for k, (i, sign) in enumerate(((a, 1.0), (b, -1.0))):
        if i >= 0:
            turn = kin.add(kin.scaled(d1, kin.vector(rows, s, TURN + 6 + 3 * k)),
                           kin.scaled(d2, kin.vector(rows, s, TURN + 12 + 3 * k)))
            _impel(velocity, inverse_mass, i, sign, j, turn)
    return max(abs(d1), abs(d2))


@helper(inline='always')
def normal_row(rows, s, velocity, inverse_mass, softness, body, lam, target):
    """One Gauss-Seidel update of contact ``s``'s normal impulse toward ``target``, kept >= 0.

    ``softness`` is the compliance over the step squared, (m/s) per (N s): a soft contact
    gives way in proportion to its impulse. ``lam`` is (C, k), its column 0 the normal.
    Returns the size of the change, N s.
    """
    a, b = body[s, 0], body[s, 1]
    vn = _speed_along(rows, s, velocity, a, b, NORMAL, MOMENT)
    # The change, not the new impulse, is what the velocities wait for: it is clipped at
    # -lam directly (the impulse stays >= 0) rather than read back off the clipped sum.
    change = max(-lam[s, 0], (target - vn - softness * lam[s, 0]) * rows[s, 18])
    lam[s, 0] += change
    j = kin.scaled(change, kin.vector(rows, s, NORMAL))
    for k, (i, sign) in enumerate(((a, 1.0), (b, -1.0))):
        if i >= 0:
            _impel(velocity, inverse_mass, i, sign, j,
                   kin.scaled(change, kin.vector(rows, s, TURN + 3 * k)))
    return abs(change)
