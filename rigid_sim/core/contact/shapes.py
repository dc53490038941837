# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Collision shapes: a body's ``collision:`` entry, or its own shape where it is a primitive.

A collision shape is centred at the body frame's origin, along its axes, as the body's
``shape`` is: ``{type: sphere, radius}``, ``{type: box, size}`` (edge lengths, m) or
``{type: none}`` (the body collides with nothing). A body without ``collision:`` collides
as its ``shape`` when that is a sphere or a box; a cylinder or mesh body in a scene that
lists contact must say its collision shape (those shapes do not collide yet).
"""
import numpy as np

from rigid_sim.core.contact.stage import BOX, SPHERE
from rigid_sim.core.scene_fields import (
    describe, fields, Mistake, positive, raw, REQUIRED, size)

COLLISION = {
    'sphere': {'radius': (positive, REQUIRED)},
    'box': {'size': (size, REQUIRED)},
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


def default_collision(shape):
    """Return the collision shape of a body whose ``shape`` is ``shape``; None: none by default."""
    if shape['type'] in ('sphere', 'box'):
        return {name: shape[name] for name in ('type', 'radius', 'size') if name in shape}
    return None


def shape_arrays(collision):
    """(N,) kinds and (N, 3) sizes (radius; half extents) of the bodies' collision shapes."""
    kind = np.zeros(len(collision), dtype=np.int64)
    extent = np.zeros((len(collision), 3))
    for i, shape in enumerate(collision):
        if shape['type'] == 'sphere':
            kind[i], extent[i, 0] = SPHERE, shape['radius']
        elif shape['type'] == 'box':
            kind[i], extent[i] = BOX, 0.5 * np.asarray(shape['size'], dtype=float)
    return kind, extent
