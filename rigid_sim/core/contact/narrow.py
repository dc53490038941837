# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Narrow phase: the contact points of one pair of primitive shapes, compiled code only.

Every test writes its contacts through :func:`emit` into :class:`Contacts` arrays: body
``a`` and ``b`` (``b < 0``: plane ``-1 - b``), a world point, the unit normal pointing from
``b`` to ``a`` (the direction ``a`` is pushed) and the signed distance along it (negative:
penetration), m. Features closer than ``margin`` (m) are written, so that bodies that just
touch (a stack falling as one in a step) are solved together. Each
contact gets a key, ``(pair, feature)``, that names the same contact at the next step, for
the solver's warm start. Shapes are centred at ``centre`` with rotation ``r`` (row-major
9-tuple, shape axes to world) and, for a box, half extents ``half`` (3-tuple), m.
"""
import math
from typing import NamedTuple

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper

SPHERE, BOX, CAPSULE, CYLINDER = 1, 2, 3, 4   # shape kinds; 0: no collision shape
# Features per pair the key keeps apart: a box-box patch has at most 8 points per reference
# face (6 faces), an edge-edge contact one of 9 edge pairs; a box on a plane 8 corners, a
# cylinder 9 rim points per cap; a support-mapping pair 1 + 30 + 18 (convex.py).
FEATURES = 64
# SAT prefers a face axis unless an edge axis separates by this fraction more: an edge
# contact gives one point, a face contact a patch, and nearly parallel faces must not flip
# between the two from one step to the next (as ODE's and Bullet's box-box tests do).
FACE_PREFERENCE = 0.95
# Cross products of edge directions shorter than this are parallel edges: no axis.
PARALLEL = 1e-9


class Contacts(NamedTuple):
    """Room for C contacts, written by :func:`emit`."""

    body: np.ndarray       # (C, 2) int: a, b (b < 0: plane -1 - b)
    key: np.ndarray        # (C,) int: pair and feature, the same contact at the next step
    point: np.ndarray      # (C, 3) m, world
    normal: np.ndarray     # (C, 3) unit, world, from b to a
    distance: np.ndarray   # (C,) m, signed, negative: penetration


@helper
def emit(contacts, count, a, b, slots, feature, point, normal, distance):
    """Write a contact at index ``count`` if there is room; return ``count + 1`` either way.

    ``slots`` is the number of bodies plus planes (a pair's key is unique through it).
    """
    if count < contacts.key.shape[0]:
        contacts.body[count, 0] = a
        contacts.body[count, 1] = b
        other = b if b >= 0 else slots + b   # planes after the bodies: N + P - 1 - p
        contacts.key[count] = (a * slots + other) * FEATURES + feature
        kin.store(contacts.point, count, 0, point)
        kin.store(contacts.normal, count, 0, normal)
        contacts.distance[count] = distance
    return count + 1


@helper
def axis(r, k):
    """Column ``k`` of the row-major rotation ``r``: the shape's ``k``-th axis in world."""
    return (r[k], r[3 + k], r[6 + k])


@helper
def sphere_plane(contacts, count, a, b, slots, margin, centre, radius, normal, offset):
    """Sphere on the plane ``normal . x = offset``: one contact at its lowest point."""
    distance = kin.dot(normal, centre) - offset - radius
    if distance >= margin:
        return count
    point = kin.plus_scaled(centre, -(radius + 0.5 * distance), normal)
    return emit(contacts, count, a, b, slots, 0, point, normal, distance)


@helper
def box_plane(contacts, count, a, b, slots, margin, centre, r, half, normal, offset):
    """Box on a plane: each corner below it, feature the corner's index."""
    for corner in range(8):
        local = (half[0] if corner & 1 else -half[0], half[1] if corner & 2 else -half[1],
                 half[2] if corner & 4 else -half[2])
        p = kin.add(centre, kin.rotate(r, local))
        distance = kin.dot(normal, p) - offset
        if distance < margin:
            point = kin.plus_scaled(p, -0.5 * distance, normal)
            count = emit(contacts, count, a, b, slots, corner, point, normal, distance)
    return count


@helper
def sphere_sphere(contacts, count, a, b, slots, margin, centre_a, radius_a, centre_b,
                  radius_b):
    """Two spheres: one contact midway between their surfaces along the centre line."""
    delta = kin.plus_scaled(centre_a, -1.0, centre_b)
    length = math.sqrt(kin.dot(delta, delta))
    distance = length - radius_a - radius_b
    if distance >= margin:
        return count
    # Concentric spheres have no direction: push along world z, as good as any.
    normal = kin.scaled(1.0 / length, delta) if length > 0.0 else (0.0, 0.0, 1.0)
    point = kin.plus_scaled(centre_b, radius_b + 0.5 * distance, normal)
    return emit(contacts, count, a, b, slots, 0, point, normal, distance)


@helper
def sphere_box_contact(centre, radius, box_centre, r, half):
    """Signed distance, point on the box and unit normal from the box to the sphere.

    Outside the box the normal is from the closest point to the centre; a centre inside
    leaves through the nearest face.
    """
    local = kin.rotate_inverse(r, kin.plus_scaled(centre, -1.0, box_centre))
    clamped = (min(max(local[0], -half[0]), half[0]), min(max(local[1], -half[1]), half[1]),
               min(max(local[2], -half[2]), half[2]))
    if clamped != local:
        # In the box's axes: a centre outside by less than round-off of the world positions
        # still has a direction there.
        delta = kin.plus_scaled(local, -1.0, clamped)
        length = math.sqrt(kin.dot(delta, delta))
        return (length - radius, kin.add(box_centre, kin.rotate(r, clamped)),
                kin.rotate(r, kin.scaled(1.0 / length, delta)))
    depth, face = half[0] - abs(local[0]), 0
    for k in (1, 2):
        if half[k] - abs(local[k]) < depth:
            depth, face = half[k] - abs(local[k]), k
    side = 1.0 if local[face] >= 0.0 else -1.0
    normal = kin.scaled(side, axis(r, face))
    closest = kin.plus_scaled(centre, depth, normal)
    return -depth - radius, closest, normal


@helper
def sphere_box(contacts, count, a, b, slots, margin, centre, radius, box_centre, r, half,
               flip):
    """Sphere and box; ``flip``: the sphere is body ``b`` (the normal then points to the box)."""
    distance, closest, normal = sphere_box_contact(centre, radius, box_centre, r, half)
    if distance >= margin:
        return count
    point = kin.plus_scaled(closest, 0.5 * distance, normal)
    if flip:
        normal = kin.scaled(-1.0, normal)
    return emit(contacts, count, a, b, slots, 0, point, normal, distance)


@helper
def _separation(direction, delta, axes_a, half_a, axes_b, half_b):
    """Gap between two boxes' projections on ``direction`` (negative: overlap), m."""
    reach = 0.0
    for k in range(3):
        reach += half_a[k] * abs(kin.dot(axes_a[k], direction))
        reach += half_b[k] * abs(kin.dot(axes_b[k], direction))
    return abs(kin.dot(delta, direction)) - reach


@helper
def _clip(polygon, size, out, direction, limit):
    """Sutherland-Hodgman: the part of ``polygon`` (first ``size`` rows) with ``d.p <= limit``.

    Written into ``out``; returns its size.
    """
    kept = 0
    for k in range(size):
        p = kin.vector(polygon, k, 0)
        q = kin.vector(polygon, (k + 1) % size, 0)
        dp, dq = kin.dot(direction, p) - limit, kin.dot(direction, q) - limit
        # A convex polygon gains at most one vertex per cut: 4 + 4 fit in the 8 rows; the
        # bound only guards against round-off making a sliver non-convex.
        if dp <= 0.0 and kept < out.shape[0]:
            kin.store(out, kept, 0, p)
            kept += 1
        if dp * dq < 0.0 and kept < out.shape[0]:   # strictly across: q is kept next
            t = dp / (dp - dq)
            kin.store(out, kept, 0, kin.plus_scaled(p, t, kin.plus_scaled(q, -1.0, p)))
            kept += 1
    return kept


@helper
def _face_patch(contacts, count, a, b, slots, margin, reference, incident, centres, axes,
                halves, face, code, flip, clip):
    """Clip the incident box's face against the reference face ``face`` of ``reference``.

    ``centres``, ``axes`` and ``halves`` are indexed by box (0: a, 1: b); ``flip``: the
    reference box is ``a``, so the normal from ``b`` to ``a`` is opposite the face's.
    """
    ref_c, inc_c = centres[reference], centres[incident]
    ref_axes, inc_axes = axes[reference], axes[incident]
    side = 1.0 if kin.dot(kin.plus_scaled(inc_c, -1.0, ref_c), ref_axes[face]) >= 0.0 else -1.0
    face_normal = kin.scaled(side, ref_axes[face])
    face_point = kin.plus_scaled(ref_c, halves[reference][face], face_normal)
    # The incident face: the one whose outward normal is most against the reference's.
    best, along = 0, kin.dot(inc_axes[0], face_normal)
    for k in (1, 2):
        dot = kin.dot(inc_axes[k], face_normal)
        if abs(dot) > abs(along):
            best, along = k, dot
    inc_half = halves[incident]
    out_normal = kin.scaled(-1.0 if along > 0.0 else 1.0, inc_axes[best])
    inc_centre = kin.plus_scaled(inc_c, inc_half[best], out_normal)
    u, v = (best + 1) % 3, (best + 2) % 3
    polygon, scratch = clip[0], clip[1]
    signs = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))
    for k in range(4):
        corner = kin.plus_scaled(inc_centre, signs[k][0] * inc_half[u], inc_axes[u])
        corner = kin.plus_scaled(corner, signs[k][1] * inc_half[v], inc_axes[v])
        kin.store(polygon, k, 0, corner)
    size = 4
    for k in (1, 2):
        side_axis = ref_axes[(face + k) % 3]
        reach = halves[reference][(face + k) % 3]
        # Up to the margin beyond the side: the corners of equal faces stacked flush lie
        # on it, where round-off would otherwise cut them off.
        limit = kin.dot(side_axis, ref_c) + reach + margin
        size = _clip(polygon, size, scratch, side_axis, limit)
        limit = -kin.dot(side_axis, ref_c) + reach + margin
        size = _clip(scratch, size, polygon, kin.scaled(-1.0, side_axis), limit)
    normal = kin.scaled(-1.0, face_normal) if flip else face_normal
    for k in range(size):
        p = kin.vector(polygon, k, 0)
        depth = kin.dot(face_normal, kin.plus_scaled(p, -1.0, face_point))
        if depth < margin:
            point = kin.plus_scaled(p, -0.5 * depth, face_normal)
            count = emit(contacts, count, a, b, slots, code * 8 + k, point, normal, depth)
    return count


@helper
def _edge_contact(contacts, count, a, b, slots, centres, axes, halves, i, j, normal,
                  distance):
    """One contact between edge ``i`` of box a and edge ``j`` of box b, midway between them."""
    # Each box's edge along the axis nearest the other box: its support in that direction.
    toward_b = kin.scaled(-1.0, normal)
    pa, pb = centres[0], centres[1]
    for k in range(3):
        if k != i:
            sa = 1.0 if kin.dot(axes[0][k], toward_b) > 0.0 else -1.0
            pa = kin.plus_scaled(pa, sa * halves[0][k], axes[0][k])
        if k != j:
            sb = 1.0 if kin.dot(axes[1][k], normal) > 0.0 else -1.0
            pb = kin.plus_scaled(pb, sb * halves[1][k], axes[1][k])
    da, db = axes[0][i], axes[1][j]
    w = kin.plus_scaled(pa, -1.0, pb)
    b_dot = kin.dot(da, db)
    d, e = kin.dot(da, w), kin.dot(db, w)
    denominator = 1.0 - b_dot * b_dot
    s = (b_dot * e - d) / denominator
    t = (e - b_dot * d) / denominator
    s = min(max(s, -halves[0][i]), halves[0][i])
    t = min(max(t, -halves[1][j]), halves[1][j])
    on_a = kin.plus_scaled(pa, s, da)
    on_b = kin.plus_scaled(pb, t, db)
    point = kin.scaled(0.5, kin.add(on_a, on_b))
    return emit(contacts, count, a, b, slots, 48 + 3 * i + j, point, normal, distance)


@helper
def box_box(contacts, count, a, b, slots, margin, centre_a, r_a, half_a, centre_b, r_b,
            half_b, clip):
    """Two boxes by the separating axis test, then a contact patch or an edge contact.

    The 15 axes (3 faces each, 9 edge pairs); the one of least overlap is the normal. A face
    axis clips the other box's most opposed face against the face's side planes (up to 8
    points); an edge pair gives the point between the closest points of the two edges.
    ``clip`` (2, 8, 3) is the clipping's scratch: the polygon and its next cut.
    """
    axes_a = (axis(r_a, 0), axis(r_a, 1), axis(r_a, 2))
    axes_b = (axis(r_b, 0), axis(r_b, 1), axis(r_b, 2))
    delta = kin.plus_scaled(centre_b, -1.0, centre_a)
    best_face, face_box, face_k = -math.inf, 0, 0
    for box, faces in enumerate((axes_a, axes_b)):   # a's face axes, then b's
        for k in range(3):
            gap = _separation(faces[k], delta, axes_a, half_a, axes_b, half_b)
            if gap >= margin:
                return count
            if gap > best_face:
                best_face, face_box, face_k = gap, box, k
    best_edge, edge_i, edge_j, edge_axis = -math.inf, 0, 0, (0.0, 0.0, 0.0)
    for i in range(3):
        for j in range(3):
            c = kin.cross(axes_a[i], axes_b[j])
            length = math.sqrt(kin.dot(c, c))
            if length < PARALLEL:
                continue
            c = kin.scaled(1.0 / length, c)
            gap = _separation(c, delta, axes_a, half_a, axes_b, half_b)
            if gap >= margin:
                return count
            if gap > best_edge:
                best_edge, edge_i, edge_j, edge_axis = gap, i, j, c
    centres = (centre_a, centre_b)
    axes = (axes_a, axes_b)
    halves = (half_a, half_b)
    # The margin too: an edge pair of aligned boxes spans a face axis and ties with it.
    if best_edge > FACE_PREFERENCE * best_face + margin:
        # From b to a: against the direction from a to b.
        normal = edge_axis if kin.dot(edge_axis, delta) < 0.0 else kin.scaled(-1.0, edge_axis)
        return _edge_contact(contacts, count, a, b, slots, centres, axes, halves, edge_i,
                             edge_j, normal, best_edge)
    incident = 1 - face_box
    return _face_patch(contacts, count, a, b, slots, margin, face_box, incident, centres,
                       axes, halves, face_k, 3 * face_box + face_k, face_box == 0, clip)


@helper
def box_box_gap(centre_a, r_a, half_a, centre_b, r_b, half_b):
    """Largest gap of two boxes' projections over the 15 axes, m (negative: overlap).

    Positive exactly when an axis separates them and zero when they touch, so it
    brackets the moment two boxes meet as their distance would (exact mode's root).
    """
    axes_a = (axis(r_a, 0), axis(r_a, 1), axis(r_a, 2))
    axes_b = (axis(r_b, 0), axis(r_b, 1), axis(r_b, 2))
    delta = kin.plus_scaled(centre_b, -1.0, centre_a)
    gap = -math.inf
    for k in range(3):
        gap = max(gap, _separation(axes_a[k], delta, axes_a, half_a, axes_b, half_b))
        gap = max(gap, _separation(axes_b[k], delta, axes_a, half_a, axes_b, half_b))
    for i in range(3):
        for j in range(3):
            c = kin.cross(axes_a[i], axes_b[j])
            length = math.sqrt(kin.dot(c, c))
            if length >= PARALLEL:
                gap = max(gap, _separation(kin.scaled(1.0 / length, c), delta, axes_a, half_a,
                                           axes_b, half_b))
    return gap
