# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Narrow phase of capsules: a segment swept by a sphere, against planes and every primitive.

A capsule is centred at ``centre`` with its segment along the unit ``direction`` (the body's
z axis), from ``-half`` to ``+half`` (m), swept by ``radius``. Every test reduces to the
segment: the capsule's signed distance to a shape is the segment's minus the radius.
Contacts are written through :func:`~rigid_sim.core.contact.narrow.emit`, with its
conventions (normal from ``b`` to ``a``, point midway between the surfaces).

- plane: the two end spheres (features 0 and 1).
- sphere: the closest point of the segment to the centre, then two spheres.
- capsule: the closest points of the two segments (feature 0), and for segments within
  :data:`PARALLEL_AXES` of parallel the two ends of their common stretch too (1, 2): a
  capsule lying along another rests on a line, not on a point.
- box: the exact signed distance, then a patch or a point. A segment outside the box: its
  distance is the least of the box's distance along the segment, a convex function of the
  position on it, found by golden section. A segment that enters the box: the separating
  axes of the segment and the box (the box's 3 face normals, and the segment's direction
  crossed with each), whose least overlap is the exact depth (the Minkowski difference of
  a box and a segment is a polytope with those face normals). A normal along a box face
  gives the segment clipped to that face's sides, its two ends a contact each (1, 2); any
  other normal one contact at the closest points (0).
"""
import math

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper
from rigid_sim.core.contact.narrow import emit, PARALLEL, sphere_sphere

# Segments whose directions' cross product is shorter than this (the sine of the angle
# between them) are parallel: the ends of their common stretch are contacts too. At this
# angle the stretch's ends lie above the closest points by at most (L 1e-3)^2 / (2 d).
PARALLEL_AXES = 1e-3
# Golden-section steps along a segment: the bracket shrinks to 0.618^80 (5e-17) of its
# length, below round-off of the positions.
GOLDEN_STEPS = 80
INVERSE_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)
# A normal this close to a box axis is that face's (a separating axis that ties with a face
# axis is the face's: it gives a patch).
FACE = 1e-12


@helper
def clamp(x, low, high):
    """``x`` held to ``[low, high]``."""
    return min(max(x, low), high)


@helper
def segment_point(centre, direction, half, point):
    """Parameter in ``[-half, half]`` of the point of the segment closest to ``point``."""
    return clamp(kin.dot(direction, kin.plus_scaled(point, -1.0, centre)), -half, half)


@helper
def closest_parameters(centre_a, dir_a, half_a, centre_b, dir_b, half_b):
    """Parameters ``(s, t)`` of the closest points of two segments (unit directions).

    Least squares of ``|w + s da - t db|^2`` over the rectangle of parameters: the free
    minimum's ``s`` held to its range, ``t`` best for that ``s``, then ``s`` best for a held
    ``t``. Parallel segments have a line of minima: ``s`` starts at 0 there.
    """
    w = kin.plus_scaled(centre_a, -1.0, centre_b)
    b = kin.dot(dir_a, dir_b)
    d, e = kin.dot(dir_a, w), kin.dot(dir_b, w)
    denominator = 1.0 - b * b
    s = clamp((b * e - d) / denominator, -half_a, half_a) if denominator > 1e-12 else 0.0
    t = e + b * s
    if t < -half_b or t > half_b:
        t = clamp(t, -half_b, half_b)
        s = clamp(b * t - d, -half_a, half_a)
    return s, t


@helper
def capsule_plane(contacts, count, a, b, slots, margin, centre, direction, half, radius,
                  normal, offset):
    """Capsule on the plane ``normal . x = offset``: its two end spheres (features 0, 1)."""
    for end in range(2):
        sign = 1.0 if end else -1.0
        sphere = kin.plus_scaled(centre, sign * half, direction)
        distance = kin.dot(normal, sphere) - offset - radius
        if distance < margin:
            point = kin.plus_scaled(sphere, -(radius + 0.5 * distance), normal)
            count = emit(contacts, count, a, b, slots, end, point, normal, distance)
    return count


@helper
def capsule_sphere(contacts, count, a, b, slots, margin, centre, direction, half, radius,
                   sphere, sphere_radius, flip):
    """Capsule and sphere; ``flip``: the capsule is body ``b``."""
    t = segment_point(centre, direction, half, sphere)
    on_segment = kin.plus_scaled(centre, t, direction)
    if flip:
        return sphere_sphere(contacts, count, a, b, slots, margin, sphere, sphere_radius,
                             on_segment, radius)
    return sphere_sphere(contacts, count, a, b, slots, margin, on_segment, radius, sphere,
                         sphere_radius)


@helper
def _spheres(contacts, count, a, b, slots, margin, feature, centre_a, radius_a, centre_b,
             radius_b):
    """Two spheres as :func:`sphere_sphere` does, with the contact's ``feature``."""
    delta = kin.plus_scaled(centre_a, -1.0, centre_b)
    length = math.sqrt(kin.dot(delta, delta))
    distance = length - radius_a - radius_b
    if distance >= margin or length == 0.0:
        return count
    normal = kin.scaled(1.0 / length, delta)
    point = kin.plus_scaled(centre_b, radius_b + 0.5 * distance, normal)
    return emit(contacts, count, a, b, slots, feature, point, normal, distance)


@helper
def capsule_capsule(contacts, count, a, b, slots, margin, centre_a, dir_a, half_a, radius_a,
                    centre_b, dir_b, half_b, radius_b):
    """Two capsules: the closest points of the segments; parallel ones their common stretch."""
    s, t = closest_parameters(centre_a, dir_a, half_a, centre_b, dir_b, half_b)
    count = _spheres(contacts, count, a, b, slots, margin, 0,
                     kin.plus_scaled(centre_a, s, dir_a), radius_a,
                     kin.plus_scaled(centre_b, t, dir_b), radius_b)
    c = kin.cross(dir_a, dir_b)
    if kin.dot(c, c) >= PARALLEL_AXES * PARALLEL_AXES:
        return count
    # b's ends projected on a's segment; their common stretch's ends are a's points.
    along = kin.plus_scaled(centre_b, -1.0, centre_a)
    middle, reach = kin.dot(dir_a, along), half_b * abs(kin.dot(dir_a, dir_b))
    low, high = max(-half_a, middle - reach), min(half_a, middle + reach)
    if high <= low:
        return count
    for feature, s in ((1, low), (2, high)):
        on_a = kin.plus_scaled(centre_a, s, dir_a)
        on_b = kin.plus_scaled(centre_b, segment_point(centre_b, dir_b, half_b, on_a), dir_b)
        count = _spheres(contacts, count, a, b, slots, margin, feature, on_a, radius_a, on_b,
                         radius_b)
    return count


@helper
def box_distance(p, half):
    """Signed distance of the point ``p`` (box axes) to the box of half extents ``half``."""
    outside, inside = 0.0, -math.inf
    for k in range(3):
        q = abs(p[k]) - half[k]
        outside += max(q, 0.0) ** 2
        inside = max(inside, q)
    return math.sqrt(outside) + min(inside, 0.0)


@helper
def _least_along(centre, direction, half, box_half):
    """Parameter along the segment (box axes) of least signed distance to the box.

    The distance is convex along a line, so golden section converges to its minimum.
    """
    low, high = -half, half
    x1 = high - INVERSE_GOLDEN * (high - low)
    x2 = low + INVERSE_GOLDEN * (high - low)
    f1 = box_distance(kin.plus_scaled(centre, x1, direction), box_half)
    f2 = box_distance(kin.plus_scaled(centre, x2, direction), box_half)
    for _ in range(GOLDEN_STEPS):
        if f1 <= f2:
            high, x2, f2 = x2, x1, f1
            x1 = high - INVERSE_GOLDEN * (high - low)
            f1 = box_distance(kin.plus_scaled(centre, x1, direction), box_half)
        else:
            low, x1, f1 = x1, x2, f2
            x2 = low + INVERSE_GOLDEN * (high - low)
            f2 = box_distance(kin.plus_scaled(centre, x2, direction), box_half)
    return x1 if f1 <= f2 else x2


@helper
def _overlap_axis(centre, direction, half, box_half):
    """Separating axes of a segment inside a box (box axes): the largest gap and its axis.

    The axis points from the box to the segment's centre. Face axes come first and an edge
    axis must beat them by more than round-off: ties are faces.
    """
    best, best_axis, edge = -math.inf, (0.0, 0.0, 1.0), -1
    for k in range(6):
        if k < 3:
            n = (1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
        else:
            unit = (1.0 if k == 3 else 0.0, 1.0 if k == 4 else 0.0, 1.0 if k == 5 else 0.0)
            n = kin.cross(direction, unit)
            length = math.sqrt(kin.dot(n, n))
            if length < PARALLEL:
                continue
            n = kin.scaled(1.0 / length, n)
        reach = (box_half[0] * abs(n[0]) + box_half[1] * abs(n[1]) + box_half[2] * abs(n[2])
                 + half * abs(kin.dot(n, direction)))
        gap = abs(kin.dot(n, centre)) - reach
        if gap > best + FACE:
            sign = 1.0 if kin.dot(n, centre) >= 0.0 else -1.0
            best, best_axis, edge = gap, kin.scaled(sign, n), k - 3
    return best, best_axis, edge


@helper
def _face_range(centre, direction, half, box_half, face, margin):
    """Parameters ``(low, high)`` of the segment above face ``face``'s sides (+ margin)."""
    low, high = -half, half
    for j in range(3):
        if j == face:
            continue
        reach = box_half[j] + margin
        if abs(direction[j]) < PARALLEL:
            if abs(centre[j]) > reach:
                return 1.0, 0.0
            continue
        t1 = (-reach - centre[j]) / direction[j]
        t2 = (reach - centre[j]) / direction[j]
        low, high = max(low, min(t1, t2)), min(high, max(t1, t2))
    return low, high


@helper
def _segment_box(centre, direction, half, box_half):
    """Segment and box in box axes: signed distance, unit normal (box to segment), a point.

    The point is the segment's closest (outside) or the box's edge point (an edge axis);
    the returned ``edge`` is -1 for a face or an outside normal.
    """
    t = _least_along(centre, direction, half, box_half)
    p = kin.plus_scaled(centre, t, direction)
    outside = box_distance(p, box_half)
    if outside > 0.0:
        held = (clamp(p[0], -box_half[0], box_half[0]), clamp(p[1], -box_half[1], box_half[1]),
                clamp(p[2], -box_half[2], box_half[2]))
        return outside, kin.scaled(1.0 / outside, kin.plus_scaled(p, -1.0, held)), held, -1
    gap, n, edge = _overlap_axis(centre, direction, half, box_half)
    if edge < 0:
        return gap, n, p, -1
    # The box's edge along axis ``edge`` that lies furthest along n, and the segment's
    # closest point to it.
    edge_centre = (0.0, 0.0, 0.0)
    for j in range(3):
        if j != edge:
            unit = (1.0 if j == 0 else 0.0, 1.0 if j == 1 else 0.0, 1.0 if j == 2 else 0.0)
            edge_centre = kin.plus_scaled(edge_centre, math.copysign(box_half[j], n[j]), unit)
    unit = (1.0 if edge == 0 else 0.0, 1.0 if edge == 1 else 0.0, 1.0 if edge == 2 else 0.0)
    _, u = closest_parameters(centre, direction, half, edge_centre, unit, box_half[edge])
    return gap, n, kin.plus_scaled(edge_centre, u, unit), edge


@helper
def capsule_box(contacts, count, a, b, slots, margin, centre, direction, half, radius,
                box_centre, r, box_half, flip):
    """Capsule and box; ``flip``: the capsule is body ``b`` (the normal then points to the box).

    Works in the box's axes; see the module's docstring for the method.
    """
    c = kin.rotate_inverse(r, kin.plus_scaled(centre, -1.0, box_centre))
    d = kin.rotate_inverse(r, direction)
    gap, n, p, edge = _segment_box(c, d, half, box_half)
    distance = gap - radius
    if distance >= margin:
        return count
    sign = -1.0 if flip else 1.0
    normal = kin.scaled(sign, kin.rotate(r, n))
    face = -1
    for k in range(3):
        if abs(n[k]) > 1.0 - FACE:
            face = k
    if face >= 0:
        low, high = _face_range(c, d, half, box_half, face, margin)
        if low <= high:
            for feature, t in ((1, low), (2, high)):
                if feature == 2 and high == low:
                    break
                e = kin.plus_scaled(c, t, d)
                depth = n[face] * e[face] - box_half[face] - radius
                if depth < margin:
                    local = kin.plus_scaled(e, -(radius + 0.5 * depth), n)
                    count = emit(contacts, count, a, b, slots, feature,
                                 kin.add(box_centre, kin.rotate(r, local)), normal, depth)
            return count
        # No stretch of the segment above the face: the deepest end alone.
        t = half if kin.dot(n, d) < 0.0 else -half
        p = kin.plus_scaled(c, t, d)
        local = kin.plus_scaled(p, -(radius + 0.5 * distance), n)
    else:   # p on the box: its closest point, or its edge's
        local = kin.plus_scaled(p, 0.5 * distance, n)
    return emit(contacts, count, a, b, slots, 0, kin.add(box_centre, kin.rotate(r, local)),
                normal, distance)
