# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Checkers for scene fields: each takes (value, key) and returns the value or raises Mistake.

A field table maps a key to (checker, default); :func:`fields` walks one, so the scene
format is written down once, as data, in :mod:`rigid_sim.core.scene`.

A message says where (the key path) and what kind of value is there, never the value: a
scene may come from a file a client named, and what the file holds is not the client's to
read (:mod:`rigid_sim.core.scene_file`).
"""
import math
import re
from functools import partial

import numpy as np

# Body and point names become topic names and frame ids (~/<body>/wrench, <body>/<point>),
# so they are REP-144 name tokens, short enough for DDS topic names.
NAME_TOKEN = re.compile(r'[A-Za-z_][A-Za-z0-9_]{0,99}\Z')
# Every scene number is at most this in magnitude and a positive one at least its inverse:
# the state's products (m v^2, I w^2, x x P) of such numbers stay far inside float64, where
# 1e200 rad/s would overflow the energy. No body a robot meets comes near either bound.
MAX_MAGNITUDE = 1e15
# Below this norm a quaternion has no direction left to normalise to.
MIN_QUATERNION_NORM = 1e-9
# A key shown in a key path as written: a name as the scene format's keys are. Another key
# (text with spaces, a number, a date) is shown by its position in its mapping.
KEY_TEXT = re.compile(r'[A-Za-z_][A-Za-z0-9_-]{0,99}\Z')
# Field-table defaults: the key must be given / the key stays out of the result when absent.
REQUIRED, ABSENT = object(), object()


class Mistake(Exception):
    """A mistake at ``key``, raised below :func:`parse_scene`, which adds the file name."""

    def __init__(self, key, reason):
        super().__init__(key, reason)
        self.key, self.reason = key or '(document)', reason


def describe(value):
    """Words for what kind of value YAML produced, for messages; never the value itself."""
    if isinstance(value, bool) or value is None:
        return {True: 'the boolean true', False: 'the boolean false', None: 'nothing'}[value]
    if isinstance(value, str):
        hint = ' (write numbers unquoted: 1.0e4)'
        looks_numeric = re.fullmatch(r'[-+.\deE]+', value)
        return f'a text of {len(value)} characters' + (hint if looks_numeric else '')
    if isinstance(value, (list, tuple)):
        return f'a list of {len(value)}'
    if isinstance(value, (int, float)):
        return 'a number'
    return 'a mapping' if isinstance(value, dict) else f'a {type(value).__name__} value'


def key_name(name, index):
    """``name`` as a key path shows it: as written if it is a name, else ``(key N)``."""
    if isinstance(name, str) and KEY_TEXT.match(name):
        return name
    return f'(key {index + 1})'


def fields(value, key, spec):
    """Return a mapping checked against ``spec``: name -> (checker(value, key), default).

    A missing key takes its default (then checked), or is refused (REQUIRED), or stays
    missing (ABSENT). An unknown key is refused with the list of valid ones.
    """
    valid = tuple(spec)
    if not isinstance(value, dict):
        raise Mistake(key, f'expected a mapping with keys {valid}, got {describe(value)}')
    prefix = f'{key}.' if key else ''
    for index, name in enumerate(value):
        if name not in spec:
            raise Mistake(f'{prefix}{key_name(name, index)}',
                          f'unknown key; valid keys: {valid}')
    for name, (_, default) in spec.items():
        if default is REQUIRED and name not in value:
            raise Mistake(f'{prefix}{name}', 'missing required key')
    return {name: check(value.get(name, default), f'{prefix}{name}')
            for name, (check, default) in spec.items() if name in value or default is not ABSENT}


def table(spec):
    return lambda value, key: fields(value, key, spec)


def list_of(check, what):
    """Return a checker of a list whose items pass ``check``."""
    def checked(value, key):
        if not isinstance(value, list):
            raise Mistake(key, f'expected a list of {what}, got {describe(value)}')
        return tuple(check(item, f'{key}[{i}]') for i, item in enumerate(value))
    return checked


def number(value, key, bound=None):
    """Check a finite float of magnitude at most MAX_MAGNITUDE.

    ``bound`` 'positive' (then at least 1 / MAX_MAGNITUDE) or 'non-negative' adds a sign
    check.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise Mistake(key, f'expected a number, got {describe(value)}')
    if isinstance(value, float) and not math.isfinite(value):
        raise Mistake(key, f'must be finite, got {value}')   # nan or inf: nothing to hide
    if (bound == 'positive' and value <= 0) or (bound == 'non-negative' and value < 0):
        raise Mistake(key, f'must be {bound}, got {"zero" if value == 0 else "less"}')
    if abs(value) > MAX_MAGNITUDE:  # an int may be too large for a float at all
        raise Mistake(key, f'must be at most {MAX_MAGNITUDE:g} in magnitude (products of '
                           'such numbers in the state would overflow), got more')
    if bound == 'positive' and value < 1.0 / MAX_MAGNITUDE:
        raise Mistake(key, f'must be at least {1.0 / MAX_MAGNITUDE:g} (its inverse scales '
                           'accelerations), got less')
    return float(value)


def count(value, key):
    """Check a positive whole number (samples, limits); an integral float such as 1e6 is one."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise Mistake(key, f'expected a whole number, got {describe(value)}')
    if value < 1:
        raise Mistake(key, 'must be positive, got less than 1')
    return value


def raw(value, key):
    return value


positive = partial(number, bound='positive')
non_negative = partial(number, bound='non-negative')


def vector(value, key, length=3, bound=None):
    """Check a (length,) float array from a YAML list of finite numbers."""
    if not isinstance(value, (list, tuple)) or len(value) != length:
        raise Mistake(key, f'expected a list of {length} numbers, got {describe(value)}')
    # The common case checked at once (a NaN fails the comparison); the rest item by item,
    # which says what is wrong where: 10 000 bodies have 50 000 vectors.
    low = {'positive': 1.0 / MAX_MAGNITUDE, 'non-negative': 0.0}.get(bound, -MAX_MAGNITUDE)
    if all(type(item) is float and low <= item <= MAX_MAGNITUDE for item in value):
        return np.array(value)
    return np.array([number(item, f'{key}[{i}]', bound) for i, item in enumerate(value)])


size = partial(vector, bound='positive')


def scale(value, key):
    """Uniform (a number) or per-axis (3 numbers) mesh scale, positive."""
    return size(value, key) if isinstance(value, list) else positive(value, key)


def quaternion(value, key):
    """Check a unit (x, y, z, w) rotation: a non-unit one is normalised, a zero one refused."""
    q = vector(value, key, 4)
    norm = np.linalg.norm(q)
    if norm < MIN_QUATERNION_NORM:
        raise Mistake(key, 'zero quaternion: no rotation to normalise')
    return q / norm


def matrix(value, key):
    if not isinstance(value, list) or len(value) != 3:
        raise Mistake(key, f'expected 3 rows of 3 numbers, got {describe(value)}')
    return np.array([vector(row, f'{key}[{i}]') for i, row in enumerate(value)])


def token(value, key):
    if not isinstance(value, str) or not NAME_TOKEN.match(value):
        raise Mistake(key, f'expected a name of at most 100 letters, digits and _ not '
                           f'starting with a digit (it becomes a topic and frame name), got '
                           f'{describe(value)}')
    return value


def choice(*valid):
    def checked(value, key):
        if value not in valid:
            raise Mistake(key, f'expected one of {valid}, got {describe(value)}')
        return value
    return checked


def of_type(kind, what):
    def checked(value, key):
        # YAML booleans are Python ints: a bool passes only as a bool, and only a bool does.
        if isinstance(value, bool) is not (kind is bool) or not isinstance(value, kind):
            raise Mistake(key, f'expected {what}, got {describe(value)}')
        return value
    return checked


def points(value, key):
    if not isinstance(value, dict):
        raise Mistake(key, f'expected a mapping of name: [x, y, z], got {describe(value)}')
    return {token(name, f'{key}.{key_name(name, index)}'): vector(point, f'{key}.{name}')
            for index, (name, point) in enumerate(value.items())}
