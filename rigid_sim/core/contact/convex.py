# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Narrow phase of any two convex shapes by their support mappings: a cylinder's other pairs.

The signed distance of two convex shapes is that of the origin to their Minkowski difference
``D = A - B``, whose support in a direction is ``A``'s minus ``B``'s in the opposite one.
GJK (Gilbert, Johnson and Keerthi) walks a simplex of support points of ``D`` toward the
origin: when the shapes are apart it ends at the closest points. When the origin is inside
``D`` (they overlap), EPA (the expanding polytope) grows a polytope of support points out
from GJK's last tetrahedron until its face nearest the origin lies on ``D``'s surface: the
depth and normal. Both stop when a support point adds less than :data:`TOLERANCE`; curved
shapes (a cylinder's rim) converge toward the exact value, not onto it.

One such contact (feature 0) is the deepest; a body resting on a flat face needs more, so
each shape's own points are tried against the other's exact distance too: a cylinder's rim
points (per cap the extreme one toward the other shape and :data:`RIM` fixed ones), a box's
corners, a capsule's end spheres. Each within the margin is a contact, its normal the other
shape's at its closest point.
"""
import math
from typing import NamedTuple

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper
from rigid_sim.core.contact.capsule import segment_point
from rigid_sim.core.contact.cylinder import cylinder_point, RIM
from rigid_sim.core.contact.narrow import (
    axis, BOX, CAPSULE, CYLINDER, emit, sphere_box_contact, SPHERE)

# m: GJK and EPA stop when the next support point gains less than this on the distance:
# the distance or depth is then within it of the exact one.
TOLERANCE = 1e-9
# Iterations at most of each; EPA's polytope's room (vertices, faces). EPA on a curved
# shape (a cylinder's rim) gains about a factor 2 each few steps.
GJK_STEPS = 128
EPA_STEPS = 160
FACES = 4 + 2 * 3 * EPA_STEPS + 16
# Feature numbers of the shapes' own points: after the deepest contact (0), a's then b's.
SHAPE_POINTS = 30


class ConvexScratch(NamedTuple):
    """GJK's and EPA's arrays: made once with the stage's scratch, not at every pair.

    Made per pair they were 16 allocations a cylinder's pair and step, EPA's ~100 kB.
    """

    simplex: np.ndarray     # (4, 3) GJK's support points of A - B, EPA's first tetrahedron
    simplex_a: np.ndarray   # (4, 3) the points of A they came from
    simplex_b: np.ndarray   # (4, 3) and of B
    weights: np.ndarray     # (4,) barycentric weights of the closest point
    edges: np.ndarray       # (3, 3) a face's edges from its first vertex
    gram: np.ndarray        # (3, 3) their dot products
    index: np.ndarray       # (3,) int: the face's other vertices
    rhs: np.ndarray         # (3,)
    vertices: np.ndarray    # (4 + EPA_STEPS, 3) EPA's polytope, A - B
    vertices_a: np.ndarray  # (4 + EPA_STEPS, 3) the points of A they came from
    vertices_b: np.ndarray  # (4 + EPA_STEPS, 3) and of B
    faces: np.ndarray       # (FACES, 3) int: vertex indices, counter-clockwise from outside
    normals: np.ndarray     # (FACES, 3) unit outward normals
    distances: np.ndarray   # (FACES,) from the origin
    alive: np.ndarray       # (FACES,) bool: still on the polytope
    horizon: np.ndarray     # (3 FACES, 2) int: the edges around the faces a point removes


def convex_scratch(room):
    """Return a :class:`ConvexScratch`; empty arrays unless ``room`` (a scene with cylinders)."""
    k = 1 if room else 0
    vertices, faces = k * (4 + EPA_STEPS), k * FACES
    return ConvexScratch(
        np.empty((4 * k, 3)), np.empty((4 * k, 3)), np.empty((4 * k, 3)), np.empty(4 * k),
        np.empty((3 * k, 3)), np.empty((3 * k, 3)), np.empty(3 * k, dtype=np.int64),
        np.empty(3 * k), np.empty((vertices, 3)), np.empty((vertices, 3)),
        np.empty((vertices, 3)), np.empty((faces, 3), dtype=np.int64), np.empty((faces, 3)),
        np.empty(faces), np.empty(faces, dtype=np.bool_), np.empty((3 * faces, 2), dtype=np.int64))


@helper
def support(kind, size, centre, r, d):
    """Return the shape's point furthest along ``d`` (not zero), world."""
    length = math.sqrt(kin.dot(d, d))
    if kind == SPHERE:
        return kin.plus_scaled(centre, size[0] / length, d)
    if kind == BOX:
        local = kin.rotate_inverse(r, d)
        corner = (math.copysign(size[0], local[0]), math.copysign(size[1], local[1]),
                  math.copysign(size[2], local[2]))
        return kin.add(centre, kin.rotate(r, corner))
    ax = axis(r, 2)
    along = kin.dot(d, ax)
    tip = kin.plus_scaled(centre, math.copysign(size[1], along), ax)
    if kind == CAPSULE:
        return kin.plus_scaled(tip, size[0] / length, d)
    across = kin.plus_scaled(d, -along, ax)
    across_length = math.sqrt(kin.dot(across, across))
    if across_length <= 1e-12 * length:   # along the axis: the cap's centre is as far
        return tip
    return kin.plus_scaled(tip, size[0] / across_length, across)


@helper
def point_distance(kind, size, centre, r, p):
    """Signed distance of the point ``p`` to the shape, its closest point and outward normal.

    The normal is zero where it has no direction (``p`` on a capsule's segment).
    """
    if kind == BOX:
        return sphere_box_contact(p, 0.0, centre, r, size)
    if kind == CYLINDER:
        return cylinder_point(p, centre, r, size[1], size[0])
    ax = axis(r, 2)
    core = kin.plus_scaled(centre, segment_point(centre, ax, size[1], p) if kind == CAPSULE
                           else 0.0, ax)
    delta = kin.plus_scaled(p, -1.0, core)
    length = math.sqrt(kin.dot(delta, delta))
    n = kin.scaled(1.0 / length, delta) if length > 0.0 else (0.0, 0.0, 0.0)
    return length - size[0], kin.plus_scaled(core, size[0], n), n


@helper
def _difference(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, d, w, wa, wb, k):
    """Write the support point of ``A - B`` along ``d`` and its parts into row ``k``."""
    pa = support(kind_a, size_a, ca, ra, d)
    pb = support(kind_b, size_b, cb, rb, kin.scaled(-1.0, d))
    kin.store(w, k, 0, kin.plus_scaled(pa, -1.0, pb))
    kin.store(wa, k, 0, pa)
    kin.store(wb, k, 0, pb)


@helper
def _solve(g, rhs, size):
    """Solve the ``size`` x ``size`` (1 to 3) system ``g x = rhs`` by Cramer's rule.

    ``g`` (3, 3) and ``rhs`` (3,) arrays. Returns the solution and whether ``g`` was far
    enough from singular (a degenerate face of the simplex has no projection of its own).
    """
    if size == 1:
        ok = g[0, 0] > 0.0
        return (rhs[0] / g[0, 0] if ok else 0.0, 0.0, 0.0), ok
    if size == 2:
        det = g[0, 0] * g[1, 1] - g[0, 1] * g[1, 0]
        if det <= 1e-14 * g[0, 0] * g[1, 1]:
            return (0.0, 0.0, 0.0), False
        return ((rhs[0] * g[1, 1] - g[0, 1] * rhs[1]) / det,
                (g[0, 0] * rhs[1] - rhs[0] * g[1, 0]) / det, 0.0), True
    c0, c1, c2 = kin.vector(g, 0, 0), kin.vector(g, 1, 0), kin.vector(g, 2, 0)  # symmetric
    r = (rhs[0], rhs[1], rhs[2])
    det = kin.dot(c0, kin.cross(c1, c2))
    if det <= 1e-14 * g[0, 0] * g[1, 1] * g[2, 2]:
        return (0.0, 0.0, 0.0), False
    return (kin.dot(r, kin.cross(c1, c2)) / det, kin.dot(c0, kin.cross(r, c2)) / det,
            kin.dot(c0, kin.cross(c1, r)) / det), True


@helper
def _closest_on_simplex(w, n, weights, edges, index, g, rhs):
    """Find the simplex's point (first ``n`` rows of ``w``) closest to the origin.

    Every face of it (vertices, edges, triangles, the tetrahedron) is tried: the origin's
    projection on its affine hull, kept when its barycentric weights are all non-negative.
    Writes the weights into ``weights`` and returns the point and the subset (a bit mask);
    ``edges`` (3, 3), ``index`` (3,), ``g`` (3, 3), ``rhs`` (3,) are scratch.
    """
    best, best_mask, best_point = math.inf, 0, (0.0, 0.0, 0.0)
    for mask in range(1, 1 << n):
        first, size = -1, 0
        for i in range(n):
            if mask & (1 << i):
                if first < 0:
                    first = i
                else:
                    kin.store(edges, size, 0, kin.plus_scaled(kin.vector(w, i, 0), -1.0,
                                                              kin.vector(w, first, 0)))
                    index[size] = i
                    size += 1
        p0 = kin.vector(w, first, 0)
        mu = (0.0, 0.0, 0.0)
        if size > 0:
            for i in range(size):
                rhs[i] = -kin.dot(kin.vector(edges, i, 0), p0)
                for j in range(size):
                    g[i, j] = kin.dot(kin.vector(edges, i, 0), kin.vector(edges, j, 0))
            mu, ok = _solve(g, rhs, size)
            if not ok:
                continue
        lam0 = 1.0 - mu[0] - mu[1] - mu[2]
        if lam0 < 0.0 or mu[0] < 0.0 or mu[1] < 0.0 or mu[2] < 0.0:
            continue
        point = p0
        for i in range(size):
            point = kin.plus_scaled(point, mu[i], kin.vector(edges, i, 0))
        norm = kin.dot(point, point)
        if norm < best:
            best, best_mask, best_point = norm, mask, point
            for i in range(4):
                weights[i] = 0.0
            weights[first] = lam0
            for i in range(size):
                weights[index[i]] = mu[i]
    return best_point, best_mask


@helper
def _keep(mask, n, w, wa, wb, weights):
    """Keep the rows of ``mask`` (and their weights) first; returns how many."""
    kept = 0
    for i in range(n):
        if mask & (1 << i):
            for k in range(3):
                w[kept, k], wa[kept, k], wb[kept, k] = w[i, k], wa[i, k], wb[i, k]
            weights[kept] = weights[i]
            kept += 1
    return kept


@helper
def _gjk(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, scratch):
    """GJK: ``(inside, n, v, pa, pb)``, the simplex's ``n`` points left in ``scratch.simplex``.

    ``inside``: the origin is in ``A - B`` (or within round-off of it); else ``v = pa - pb``
    is ``A - B``'s closest point to the origin, ``pa`` and ``pb`` the shapes' closest points.
    """
    w, wa, wb = scratch.simplex, scratch.simplex_a, scratch.simplex_b
    weights, edges, g = scratch.weights, scratch.edges, scratch.gram
    index, rhs = scratch.index, scratch.rhs
    for array in (weights, rhs):   # zeros, as each pair found them when they were its own
        array[:] = 0.0
    for array in (edges, g):
        array[:] = 0.0
    index[:] = 0
    v = kin.plus_scaled(ca, -1.0, cb)
    if kin.dot(v, v) == 0.0:
        v = (1.0, 0.0, 0.0)
    n = 0
    for _ in range(GJK_STEPS):
        _difference(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, kin.scaled(-1.0, v), w,
                    wa, wb, n)
        gain = kin.dot(v, v) - kin.dot(v, kin.vector(w, n, 0))
        if n > 0 and gain <= TOLERANCE * math.sqrt(kin.dot(v, v)):
            break   # the new point brings the simplex no nearer the origin
        n += 1
        v, mask = _closest_on_simplex(w, n, weights, edges, index, g, rhs)
        n = _keep(mask, n, w, wa, wb, weights)
        if n == 4 or kin.dot(v, v) < 1e-24:
            return True, n, v, v, v
    pa, pb = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    for i in range(n):
        pa = kin.plus_scaled(pa, weights[i], kin.vector(wa, i, 0))
        pb = kin.plus_scaled(pb, weights[i], kin.vector(wb, i, 0))
    return False, n, v, pa, pb


@helper
def _face(vertices, faces, normals, distances, f, i, j, k):
    """Set face ``f`` to the triangle ``i, j, k`` (counter-clockwise seen from outside)."""
    faces[f, 0], faces[f, 1], faces[f, 2] = i, j, k
    p = kin.vector(vertices, i, 0)
    n = kin.cross(kin.plus_scaled(kin.vector(vertices, j, 0), -1.0, p),
                  kin.plus_scaled(kin.vector(vertices, k, 0), -1.0, p))
    length = math.sqrt(kin.dot(n, n))
    if length == 0.0:   # a sliver: never the nearest face
        kin.store(normals, f, 0, (0.0, 0.0, 0.0))
        distances[f] = math.inf
        return
    n = kin.scaled(1.0 / length, n)
    kin.store(normals, f, 0, n)
    distances[f] = kin.dot(n, p)


@helper
def _full_tetrahedron(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, w, wa, wb, n):
    """Grow GJK's simplex (``n`` points about the origin) to a tetrahedron; returns its size.

    Support points along directions off the simplex's hull; the origin stays inside or on it.
    """
    units = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    for _ in range(12):
        if n >= 4:
            break
        best = (0.0, 0.0, 0.0)
        if n == 3:
            p = kin.vector(w, 0, 0)
            best = kin.cross(kin.plus_scaled(kin.vector(w, 1, 0), -1.0, p),
                             kin.plus_scaled(kin.vector(w, 2, 0), -1.0, p))
        else:
            edge = (kin.plus_scaled(kin.vector(w, 1, 0), -1.0, kin.vector(w, 0, 0)) if n == 2
                    else (1.0, 0.0, 0.0))
            size = 0.0
            for u in units:   # the axis most across the edge
                c = kin.cross(edge, u) if n == 2 else u
                if kin.dot(c, c) > size:
                    best, size = c, kin.dot(c, c)
                if n == 1:
                    break
        if kin.dot(best, best) == 0.0:
            return n
        grown = False
        for sign in (1.0, -1.0):
            if grown:
                break
            _difference(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, kin.scaled(sign, best),
                        w, wa, wb, n)
            gap = abs(kin.dot(best, kin.plus_scaled(kin.vector(w, n, 0), -1.0,
                                                    kin.vector(w, 0, 0))))
            grown = gap > 1e-12 * math.sqrt(kin.dot(best, best))
        if not grown:   # A - B is flat: no tetrahedron about the origin
            return n
        n += 1
    return n


@helper
def _epa(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, scratch):
    """EPA from GJK's tetrahedron about the origin: depth, outward unit normal of ``D``, pa, pb."""
    vertices, va, vb = scratch.vertices, scratch.vertices_a, scratch.vertices_b
    faces, normals, distances = scratch.faces, scratch.normals, scratch.distances
    alive, edges = scratch.alive, scratch.horizon
    alive[:] = False
    vertices[:4] = scratch.simplex[:4]
    va[:4] = scratch.simplex_a[:4]
    vb[:4] = scratch.simplex_b[:4]
    for f, (i, j, k, opposite) in enumerate(((0, 1, 2, 3), (0, 3, 1, 2), (0, 2, 3, 1),
                                             (1, 3, 2, 0))):
        _face(vertices, faces, normals, distances, f, i, j, k)
        away = kin.dot(kin.vector(normals, f, 0), kin.plus_scaled(
            kin.vector(vertices, opposite, 0), -1.0, kin.vector(vertices, i, 0)))
        if away > 0.0:   # the opposite vertex is outside: wound the other way
            _face(vertices, faces, normals, distances, f, i, k, j)
        alive[f] = True
    nv, nf, kept, kept_least = 4, 4, -1, -math.inf
    for _ in range(EPA_STEPS):
        nearest, least = -1, math.inf
        for f in range(nf):
            if alive[f] and distances[f] < least:
                nearest, least = f, distances[f]
        # The nearest face only moves out as the polytope grows inside D; one that came
        # nearer is round-off's (a point almost on a face): keep the last good face.
        if nearest < 0 or least < kept_least:
            break
        kept, kept_least = nearest, least
        n = kin.vector(normals, nearest, 0)
        _difference(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, n, vertices, va, vb, nv)
        if kin.dot(n, kin.vector(vertices, nv, 0)) - least <= TOLERANCE or nf + 64 > FACES:
            break
        p = kin.vector(vertices, nv, 0)
        count = 0
        for f in range(nf):
            if not alive[f]:
                continue
            if kin.dot(kin.vector(normals, f, 0),
                       kin.plus_scaled(p, -1.0, kin.vector(vertices, faces[f, 0], 0))) <= 1e-14:
                continue
            alive[f] = False
            for e in range(3):
                i, j = faces[f, e], faces[f, (e + 1) % 3]
                shared = -1
                for m in range(count):
                    if edges[m, 0] == j and edges[m, 1] == i:
                        shared = m
                if shared >= 0:   # inside the removed patch: not on its horizon
                    count -= 1
                    edges[shared, 0], edges[shared, 1] = edges[count, 0], edges[count, 1]
                else:
                    edges[count, 0], edges[count, 1] = i, j
                    count += 1
        for m in range(min(count, FACES - nf)):
            _face(vertices, faces, normals, distances, nf, edges[m, 0], edges[m, 1], nv)
            alive[nf] = True
            nf += 1
        nv += 1
    if kept < 0:   # no face to start from (a flat tetrahedron)
        return -math.inf, (0.0, 0.0, 1.0), ca, cb
    # The origin's projection on the nearest face, in its barycentric weights.
    nearest = kept
    n, depth = kin.vector(normals, nearest, 0), distances[nearest]
    i, j, k = faces[nearest, 0], faces[nearest, 1], faces[nearest, 2]
    p0 = kin.vector(vertices, i, 0)
    e1 = kin.plus_scaled(kin.vector(vertices, j, 0), -1.0, p0)
    e2 = kin.plus_scaled(kin.vector(vertices, k, 0), -1.0, p0)
    q = kin.plus_scaled(kin.scaled(depth, n), -1.0, p0)
    d11, d12, d22 = kin.dot(e1, e1), kin.dot(e1, e2), kin.dot(e2, e2)
    det = d11 * d22 - d12 * d12
    s = (d22 * kin.dot(q, e1) - d12 * kin.dot(q, e2)) / det if det > 0.0 else 0.0
    t = (d11 * kin.dot(q, e2) - d12 * kin.dot(q, e1)) / det if det > 0.0 else 0.0
    pa, pb = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    for weight, row in ((1.0 - s - t, i), (s, j), (t, k)):
        pa = kin.plus_scaled(pa, weight, kin.vector(va, row, 0))
        pb = kin.plus_scaled(pb, weight, kin.vector(vb, row, 0))
    return depth, n, pa, pb


@helper
def _own_points(contacts, count, a, b, slots, margin, kind, size, centre, r, other_kind,
                other_size, other_centre, other_r, toward, is_a, first):
    """Write the shape's own points that touch the other (the module says which points).

    ``toward`` points from this shape to the other; ``is_a``: this shape is body ``a``.
    """
    sign = 1.0 if is_a else -1.0
    corners = 8 if kind == BOX else (2 if kind == CAPSULE else 2 * (RIM + 1))
    ax, ux, uy = axis(r, 2), axis(r, 0), axis(r, 1)
    across = kin.plus_scaled(toward, -kin.dot(toward, ax), ax)
    across_length = math.sqrt(kin.dot(across, across))
    for c in range(corners):
        radius = 0.0
        if kind == BOX:
            local = (math.copysign(size[0], (c & 1) - 0.5), math.copysign(size[1], (c & 2) - 1.0),
                     math.copysign(size[2], (c & 4) - 2.0))
            p = kin.add(centre, kin.rotate(r, local))
        elif kind == CAPSULE:
            p, radius = kin.plus_scaled(centre, size[1] if c else -size[1], ax), size[0]
        else:
            cap, k = c // (RIM + 1), c % (RIM + 1)
            p = kin.plus_scaled(centre, size[1] if cap else -size[1], ax)
            if k == 0:   # the rim's extreme point toward the other shape
                if across_length <= 1e-12:
                    continue
                p = kin.plus_scaled(p, size[0] / across_length, across)
            else:
                angle = 2.0 * math.pi * (k - 1) / RIM
                p = kin.plus_scaled(p, size[0] * math.cos(angle), ux)
                p = kin.plus_scaled(p, size[0] * math.sin(angle), uy)
        distance, closest, n = point_distance(other_kind, other_size, other_centre, other_r, p)
        distance -= radius
        if distance >= margin or kin.dot(n, n) == 0.0:
            continue
        point = kin.plus_scaled(closest, 0.5 * distance, n)
        count = emit(contacts, count, a, b, slots, first + c, point, kin.scaled(sign, n),
                     distance)
    return count


@helper
def convex_pair(contacts, count, a, b, slots, margin, kind_a, size_a, ca, ra, kind_b, size_b,
                cb, rb, scratch):
    """Two convex shapes: the deepest contact by GJK/EPA (feature 0), then their own points.

    ``scratch`` is the :class:`ConvexScratch` GJK and EPA work in.
    """
    inside, n, v, pa, pb = _gjk(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, scratch)
    if not inside:
        distance = math.sqrt(kin.dot(v, v))
        if distance >= margin:
            return count
        normal = kin.scaled(1.0 / distance, v)   # from b to a
    else:
        if _full_tetrahedron(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, scratch.simplex,
                             scratch.simplex_a, scratch.simplex_b, n) < 4:
            return count   # A - B is flat (a degenerate shape): no depth to find
        depth, outward, pa, pb = _epa(kind_a, size_a, ca, ra, kind_b, size_b, cb, rb, scratch)
        if depth == -math.inf:
            return count
        distance, normal = -depth, kin.scaled(-1.0, outward)
    point = kin.scaled(0.5, kin.add(pa, pb))
    count = emit(contacts, count, a, b, slots, 0, point, normal, distance)
    count = _own_points(contacts, count, a, b, slots, margin, kind_a, size_a, ca, ra, kind_b,
                        size_b, cb, rb, kin.scaled(-1.0, normal), True, 1)
    return _own_points(contacts, count, a, b, slots, margin, kind_b, size_b, cb, rb, kind_a,
                       size_a, ca, ra, normal, False, 1 + SHAPE_POINTS)
