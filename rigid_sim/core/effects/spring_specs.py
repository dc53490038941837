# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Springs as the scene gives them: an entry's fields and its ends, named bodies, resolved.

The fields of one entry are checked by the table :data:`SPRING`; :func:`resolve_springs`
then makes the named ends indices into the scene's bodies, once every body is known, and
refuses what a field alone cannot show (an end on no body, a spring whose ends start at one
point with a rest length). The effect itself is :mod:`rigid_sim.core.effects.springs`.
"""
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core.scene_fields import ABSENT, Mistake, non_negative, REQUIRED, token, vector

ZERO = [0.0, 0.0, 0.0]
# A spring's scene entry; its ends name bodies, resolved by resolve_springs.
SPRING = {'body': (token, REQUIRED), 'stiffness': (non_negative, REQUIRED),
          'point': (vector, ZERO), 'anchor': (vector, ABSENT), 'other': (token, ABSENT),
          'other_point': (vector, ABSENT), 'damping': (non_negative, 0.0),
          'rest_length': (non_negative, 0.0)}
# Spring ends closer than this fraction of the rest length count as one point.
COINCIDENT = 1e-9


@dataclass(frozen=True)
class SpringSpec:
    """One spring, as the scene gives it."""

    body: int                  # index of the first body
    point: np.ndarray          # (3,) m, attachment in the first body's frame
    stiffness: float           # N/m
    damping: float = 0.0       # N s/m
    rest_length: float = 0.0   # m
    anchor: np.ndarray = None  # (3,) m, world; set when the spring ends in the world
    other: int = None          # index of the second body; set when it ends on a body
    other_point: np.ndarray = None  # (3,) m, in the second body's frame


def _spring(spring, key, names):
    """Return a :class:`SpringSpec` from checked fields, ending at an anchor or an other body."""
    if ('anchor' in spring) == ('other' in spring):
        raise Mistake(key, 'give exactly one of anchor (a world point) or other (a body)')
    if 'other_point' in spring and 'other' not in spring:
        raise Mistake(f'{key}.other_point', 'other_point needs other (a body)')
    for end in ('body', 'other'):
        if end in spring and spring[end] not in names:
            raise Mistake(f'{key}.{end}', f'no body named {spring[end]!r}; bodies: {names}')
    index = {end: names.index(spring[end]) if end in spring else None
             for end in ('body', 'other')}
    if index['other'] == index['body']:
        raise Mistake(f'{key}.other', 'a spring from a body to itself exerts no net force')
    if index['other'] is not None:
        spring.setdefault('other_point', np.zeros(3))
    return SpringSpec(**{**spring, **index})


def _end_in_world(body, point):
    """(3,) world position of body-frame ``point`` of ``body`` (a BodySpec) at the start."""
    turn = Rotation.from_quat(body.orientation)
    return body.origin + turn.apply(np.asarray(point, dtype=float))


def _check_ends_apart(spec, key, bodies):
    """Refuse a spring with a rest length whose ends start at one point.

    Its force ``k (|d| - r) d / |d|`` would have no direction there (it would read as zero).
    """
    if spec.rest_length == 0.0:
        return
    start = _end_in_world(bodies[spec.body], spec.point)
    end = (spec.anchor if spec.other is None
           else _end_in_world(bodies[spec.other], spec.other_point))
    if np.linalg.norm(end - start) <= COINCIDENT * spec.rest_length:
        raise Mistake(key, f'the spring starts with both ends at {start.tolist()}: with '
                           f'rest_length {spec.rest_length} its force has no direction')


def resolve_springs(entries, key, bodies):
    """Return a :class:`SpringSpec` per checked entry of ``entries``, ends made indices.

    Parameters
    ----------
    entries : sequence of dict
        The entries under ``key``, each checked by :data:`SPRING`.
    key : str
        Where they are in the scene, for messages (``effects.springs``).
    bodies : sequence of BodySpec
        The scene's bodies, whose names the ends give.

    Returns
    -------
    tuple of SpringSpec
        In the order of ``entries``. Raises Mistake naming the entry and the reason.
    """
    names = [body.name for body in bodies]
    specs = tuple(_spring(entry, f'{key}[{i}]', names) for i, entry in enumerate(entries))
    for i, spec in enumerate(specs):
        _check_ends_apart(spec, f'{key}[{i}]', bodies)
    return specs
