# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Collision shapes: a body's ``collision:`` entry, or its own shape where it is a primitive.

A collision shape is centred at the body frame's origin, along its axes, as the body's
``shape`` is: ``{type: sphere, radius}``, ``{type: box, size}`` (edge lengths, m),
``{type: capsule, radius, length}`` (a segment of ``length`` along body z, centred, swept by
``radius``: ``length + 2 radius`` end to end, as SDFormat and FCL measure it),
``{type: cylinder, radius, length}`` (along body z, centred, as a body's cylinder ``shape``)
or ``{type: none}`` (the body collides with nothing). A body without ``collision:``
collides as its ``shape`` when that is a sphere, box or cylinder; a mesh body in a scene
that lists contact must say its collision shape (meshes do not collide yet). Every shape
collides with every other and with the planes.
"""
import numpy as np

from rigid_sim.core.contact.narrow import BOX, CAPSULE, CYLINDER, SPHERE
from rigid_sim.core.scene_fields import (
    describe, fields, Mistake, positive, raw, REQUIRED, size)

COLLISION = {
    'sphere': {'radius': (positive, REQUIRED)},
    'box': {'size': (size, REQUIRED)},
    'capsule': {'radius': (positive, REQUIRED), 'length': (positive, REQUIRED)},
    'cylinder': {'radius': (positive, REQUIRED), 'length': (positive, REQUIRED)},
    'none': {},
}


def collision_shape(value, key):
    """Check a body's ``collision:`` entry; returns the shape dict."""
    kind = value.get('type') if isinstance(value, dict) else None
    if not isinstance(kind, str) or kind not in COLLISION:
        where = f'{key}.type' if isinstance(value, dict) else key
        raise Mistake(where, f'expected a collision type in {tuple(COLLISION)}, got '
                             f'{describe(kind if where != key else value)}')
    return fields(value, key, {'type': (raw, REQUIRED), **COLLISION[kind]})


# Exact mode finds an impact's moment on the gap of spheres and boxes alone (impact.py).
EXACT_KINDS = ('sphere', 'box', 'none')


def exact_refusal(collision, mode):
    """Why a body of ``collision`` shape cannot be in a scene of contact ``mode``; None: it can."""
    if mode == 'exact' and collision['type'] not in EXACT_KINDS:
        return (f'a {collision["type"]} collision shape has no exact-mode impacts yet (spheres '
                'and boxes have): use contact mode velocity')
    return None


def default_collision(shape):
    """Return the collision shape of a body whose ``shape`` is ``shape``; None: none by default."""
    if shape['type'] in ('sphere', 'box', 'cylinder'):
        return {name: shape[name] for name in ('type', 'radius', 'size', 'length')
                if name in shape}
    return None


def shape_arrays(collision):
    """(N,) kinds and (N, 3) sizes of the bodies' collision shapes.

    A sphere's radius, a box's half extents, a capsule's or cylinder's radius and half length.
    """
    kind = np.zeros(len(collision), dtype=np.int64)
    extent = np.zeros((len(collision), 3))
    for i, shape in enumerate(collision):
        if shape['type'] == 'sphere':
            kind[i], extent[i, 0] = SPHERE, shape['radius']
        elif shape['type'] == 'box':
            kind[i], extent[i] = BOX, 0.5 * np.asarray(shape['size'], dtype=float)
        elif shape['type'] in ('capsule', 'cylinder'):
            kind[i] = CAPSULE if shape['type'] == 'capsule' else CYLINDER
            extent[i, :2] = shape['radius'], 0.5 * shape['length']
    return kind, extent
