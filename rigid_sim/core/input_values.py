# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Numbers sent from outside while a world runs: one check for every input.

A wrench, a pose or a twist a client sends goes into the sums the kernels read or into the
state itself, so each of its components must be a number a scene could hold: finite, at
most the scene's number bound ``MAX_MAGNITUDE`` (1e15) in magnitude, and not subnormal.
The bound is the one the scene loader puts on initial poses and twists: below it the
momenta ``P = M v`` and ``L = I omega`` of any body a scene can describe, and its energy,
stay far inside float64 (1e15 kg x 1e15 m/s is 1e30), so a state set from outside is as
finite as a loaded one; 1e308 m/s on a 2 kg body would overflow ``P`` to inf. A subnormal
non-zero component is never a real quantity (1e-308 N, m or rad/s), but is what an int
assigned to a float64 field becomes with the rclpy wheels (15 arrives as 15 x 5e-324),
which would silently push or set nothing.
"""
import math
from typing import NamedTuple

import numpy as np

from rigid_sim.core.scene_fields import MAX_MAGNITUDE

SMALLEST_NORMAL = float(np.finfo(float).tiny)


class NormLimit(NamedTuple):
    """A bound on a vector's Euclidean norm, named as the refusal names it."""

    value: float   # the bound, in ``unit``
    name: str      # the scene key that sets it: 'max_force'
    unit: str      # 'N'


def checked(name, values, axes='xyz', limit=None):
    """Return ``values`` as a float array if every input check passes, else ValueError.

    The checks, in order: each component finite and not subnormal; the norm within
    ``limit``; each component at most ``MAX_MAGNITUDE`` in magnitude. The reason names the
    first component that fails (``force.x``, ``orientation.w``).

    Parameters
    ----------
    name : str
        What the vector is, as the message calls it: ``force``, ``position``, ``linear``.
    values : array_like
        One number per axis.
    axes : str
        The components' names, in order: ``xyz``, or ``xyzw`` for a quaternion.
    limit : NormLimit or None
        The scene's bound on the norm (``max_force``). It is checked before the
        per-component bound, which it never exceeds, so a refusal names the scene's limit.

    Returns
    -------
    (len(axes),) float ndarray
    """
    values = np.asarray(values, dtype=float)
    if values.shape != (len(axes),):
        raise ValueError(f'{name} must have {len(axes)} components, got shape {values.shape}')
    components = list(zip(axes, values.tolist()))
    for axis, value in components:
        if not math.isfinite(value):
            raise ValueError(f'non-finite {name}.{axis}: {value}')
        if value != 0.0 and abs(value) < SMALLEST_NORMAL:
            raise ValueError(f'{name}.{axis} is {value:.3g}, a subnormal number: write floats '
                             '(15.0): an int in a float64 field arrives as 5e-324')
    if limit is not None:
        # hypot: a 1e300 component overflows no square; repr: 20.0001 is not shown as 20.
        norm = math.hypot(*values)
        if norm > limit.value:
            raise ValueError(f'|{name}| {norm!r} {limit.unit} above the scene limit '
                             f'{limit.name} {limit.value!r} {limit.unit}')
    for axis, value in components:
        if abs(value) > MAX_MAGNITUDE:
            raise ValueError(f'{name}.{axis} is {value!r}, above {MAX_MAGNITUDE:g} in '
                             'magnitude, the bound of every scene number (beyond it the '
                             "state's momenta and energy overflow)")
    return values
