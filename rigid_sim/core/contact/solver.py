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


@helper(inline='always')
def _push(velocity, impulse, inverse_mass, inv_inertia, i, arm, j, sliding):
    """Apply the impulse ``j`` at ``arm`` to body ``i``: its velocities and (if kept) sums.

    ``impulse`` (N, 9) sums the linear and angular impulses, then the linear impulse of
    friction alone (``sliding``); an empty one keeps none.
    """
    moment = kin.cross(arm, j)
    turn = kin.rotate(kin.entries(inv_inertia, i), moment)
    for k in range(3):
        velocity[i, k] += inverse_mass[i] * j[k]
        velocity[i, 3 + k] += turn[k]
    if impulse.shape[0] > 0:
        for k in range(3):
            impulse[i, k] += j[k]
            impulse[i, 3 + k] += moment[k]
            if sliding:
                impulse[i, 6 + k] += j[k]


@helper(inline='always')
def apply(velocity, impulse, inverse_mass, inv_inertia, a, b, arm_a, arm_b, j, sliding):
    """Apply ``j`` to ``a`` and ``-j`` to ``b`` (none for a plane) at their arms.

    ``impulse`` (N, 9) sums each body's linear and angular impulse, then (``sliding``:
    ``j`` is friction) friction's linear impulse alone; an empty one keeps none (the
    pseudo-velocities of the position correction).
    """
    _push(velocity, impulse, inverse_mass, inv_inertia, a, arm_a, j, sliding)
    if b >= 0:
        _push(velocity, impulse, inverse_mass, inv_inertia, b, arm_b, kin.scaled(-1.0, j),
              sliding)


@helper(inline='always')
def friction_row(rows, s, velocity, impulse, inverse_mass, inv_inertia, mu, body, lam):
    """One Gauss-Seidel update of contact ``s``'s tangential impulse, kept in the cone.

    ``rows`` (C, 24): arm a, arm b, normal, tangent 1, tangent 2, the tangential mass, two
    spare, the normal mass, the normal target, the approach speed, the distance, the rigid
    normal mass, the correction's target. Returns the largest change of a component, N s.
    """
    a, b = body[s, 0], body[s, 1]
    arm_a, arm_b = kin.vector(rows, s, 0), kin.vector(rows, s, 3)
    t1, t2 = kin.vector(rows, s, 9), kin.vector(rows, s, 12)
    v = relative_velocity(velocity, a, b, arm_a, arm_b)
    v1, v2 = kin.dot(t1, v), kin.dot(t2, v)
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
    apply(velocity, impulse, inverse_mass, inv_inertia, a, b, arm_a, arm_b, j, True)
    return max(abs(d1), abs(d2))


@helper(inline='always')
def normal_row(rows, s, velocity, impulse, inverse_mass, inv_inertia, softness, body, lam,
               target):
    """One Gauss-Seidel update of contact ``s``'s normal impulse toward ``target``, kept >= 0.

    ``softness`` is the compliance over the step squared, (m/s) per (N s): a soft contact
    gives way in proportion to its impulse. ``lam`` is (C, k), its column 0 the normal.
    Returns the size of the change, N s.
    """
    a, b = body[s, 0], body[s, 1]
    arm_a, arm_b, n = kin.vector(rows, s, 0), kin.vector(rows, s, 3), kin.vector(rows, s, 6)
    vn = kin.dot(n, relative_velocity(velocity, a, b, arm_a, arm_b))
    new = max(0.0, lam[s, 0] - (vn + softness * lam[s, 0] - target) * rows[s, 18])
    change = new - lam[s, 0]
    lam[s, 0] = new
    apply(velocity, impulse, inverse_mass, inv_inertia, a, b, arm_a, arm_b,
          kin.scaled(change, n), False)
    return abs(change)
