# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Narrow phase of solid cylinders against planes and spheres.

A cylinder is centred at ``centre``, its axis the body's z (column 2 of ``r``, row-major
9-tuple), its caps at ``-half`` and ``+half`` along it, of ``radius`` (m). Contacts are
written through :func:`~rigid_sim.core.contact.narrow.emit`, with its conventions.

- plane: per cap, its rim's lowest point, exact (feature ``9 cap``), and :data:`RIM`
  points fixed on the rim (``9 cap + 1 ...``), each where it is within the margin: a
  cylinder lying on its side rests on the two lowest points (a line), one tilted on its
  edge on one, one standing on a cap on the fixed rim points (a patch that stays the same
  points, step after step, for the warm start).
- sphere: the closest point of the solid cylinder to the sphere's centre (a centre inside
  leaves through the nearest of the side and the caps), exact.
"""
import math

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper
from rigid_sim.core.contact.narrow import axis, emit

# Fixed points on each cap's rim, evenly spaced: what a cylinder standing on a cap rests on.
RIM = 8
# A plane's normal this close to the axis has no lowest rim point of its own: the fixed
# rim points carry the cap.
ALONG_AXIS = 1e-12


@helper
def cylinder_plane(contacts, count, a, b, slots, margin, centre, r, half, radius, normal,
                   offset):
    """Cylinder on the plane ``normal . x = offset``: rim points of the caps below it."""
    ax, ux, uy = axis(r, 2), axis(r, 0), axis(r, 1)
    along = kin.dot(normal, ax)
    across = kin.plus_scaled(normal, -along, ax)   # the normal's part in the cap's plane
    across_length = math.sqrt(kin.dot(across, across))
    for cap in range(2):
        cap_centre = kin.plus_scaled(centre, half if cap else -half, ax)
        if across_length > ALONG_AXIS:
            p = kin.plus_scaled(cap_centre, -radius / across_length, across)
            count = _rim_contact(contacts, count, a, b, slots, margin, 9 * cap, p, normal,
                                 offset)
        for k in range(RIM):
            angle = 2.0 * math.pi * k / RIM
            p = kin.plus_scaled(cap_centre, radius * math.cos(angle), ux)
            p = kin.plus_scaled(p, radius * math.sin(angle), uy)
            count = _rim_contact(contacts, count, a, b, slots, margin, 9 * cap + 1 + k, p,
                                 normal, offset)
    return count


@helper
def _rim_contact(contacts, count, a, b, slots, margin, feature, p, normal, offset):
    """Write the contact of the cylinder's point ``p`` with a plane, if within the margin."""
    distance = kin.dot(normal, p) - offset
    if distance >= margin:
        return count
    point = kin.plus_scaled(p, -0.5 * distance, normal)
    return emit(contacts, count, a, b, slots, feature, point, normal, distance)


@helper
def cylinder_point(point, centre, r, half, radius):
    """Signed distance of ``point`` to the solid cylinder, its closest surface point, normal.

    The normal is the cylinder's outward one there (from the surface to an outside point).
    """
    local = kin.rotate_inverse(r, kin.plus_scaled(point, -1.0, centre))
    rho = math.sqrt(local[0] * local[0] + local[1] * local[1])
    # The radial unit: any, on the axis itself (x, as good as any).
    radial = (local[0] / rho, local[1] / rho, 0.0) if rho > 0.0 else (1.0, 0.0, 0.0)
    side = radius - rho
    cap = half - abs(local[2])
    up = (0.0, 0.0, 1.0 if local[2] >= 0.0 else -1.0)
    if side >= 0.0 and cap >= 0.0:   # inside: out through the nearest of side and caps
        if side <= cap:
            held, n = kin.plus_scaled(local, side, radial), radial
        else:
            held, n = kin.plus_scaled(local, cap, up), up
        return (-min(side, cap), kin.add(centre, kin.rotate(r, held)),
                kin.rotate(r, n))
    z = min(max(local[2], -half), half)
    reach = min(rho, radius)
    held = (reach * radial[0], reach * radial[1], z)
    delta = kin.plus_scaled(local, -1.0, held)
    distance = math.sqrt(kin.dot(delta, delta))
    # Outside by less than round-off resolves (a point on the rim): out across the side.
    n = kin.scaled(1.0 / distance, delta) if distance > 0.0 else (radial if side < 0.0 else up)
    return distance, kin.add(centre, kin.rotate(r, held)), kin.rotate(r, n)


@helper
def cylinder_sphere(contacts, count, a, b, slots, margin, centre, r, half, radius, sphere,
                    sphere_radius, flip):
    """Cylinder and sphere; ``flip``: the cylinder is body ``b``."""
    gap, closest, normal = cylinder_point(sphere, centre, r, half, radius)
    distance = gap - sphere_radius
    if distance >= margin:
        return count
    point = kin.plus_scaled(closest, 0.5 * distance, normal)
    # ``normal`` points from the cylinder to the sphere.
    if not flip:
        normal = kin.scaled(-1.0, normal)
    return emit(contacts, count, a, b, slots, 0, point, normal, distance)
