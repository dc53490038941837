# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Linear springs with dampers between body points and world anchors or other bodies.

Each spring pulls its two attachment points together with
``f = -(k (l - l0) + c dl/dt) u`` along the unit vector ``u`` from the second end to the
first; the torque on a body is ``(p - x) x f``. With ``l0 = 0`` the force is the full vector
``-k d - c d'`` and stays defined when the points meet.

Springs that all end in the world act on one body each: they then get a kernel of one body,
so that the integrators may take each body through a whole step in registers.
"""
import math
from typing import NamedTuple

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.effects.base import Effect, body_kernel_for, kernel_for
from rigid_sim.core.effects.spring_specs import resolve_springs, SPRING
# Re-exported: a spring as the scene gives it is what this effect is built from.
from rigid_sim.core.effects.spring_specs import SpringSpec  # noqa: F401
from rigid_sim.core.scene_fields import list_of, table


class SpringParameters(NamedTuple):
    """The S springs as arrays, what the compiled kernel reads."""

    body: np.ndarray         # (S,) int, first body
    lever: np.ndarray        # (S, 3) m, first end from its centre of mass, body axes
    stiffness: np.ndarray    # (S,) N/m
    damping: np.ndarray      # (S,) N s/m
    rest: np.ndarray         # (S,) m
    other: np.ndarray        # (S,) int, second body, -1 for a world anchor
    other_lever: np.ndarray  # (S, 3) m, second end from its centre of mass, body axes
    anchor: np.ndarray       # (S, 3) m, world anchor (unused for a second body)


class AnchoredSpringParameters(NamedTuple):
    """S springs that each end in the world, grouped by body, as the kernel of one body reads.

    Two arrays only: every array a compiled kernel takes out of its parameters is a
    reference count it keeps across its loop over the body's springs.
    """

    first: np.ndarray   # (N + 1,) int: body i's springs are rows first[i] to first[i + 1] - 1
    # (S, 9): lever (m, body axes, from the centre of mass), anchor (m, world), stiffness
    # N/m, damping N s/m (column DAMPING_COLUMN), rest length m; each body's springs in the
    # scene's order.
    rows: np.ndarray


DAMPING_COLUMN = 7   # of AnchoredSpringParameters.rows (read by goal_twosided's reversal)


class Springs(Effect):
    """All springs of a scene, evaluated together."""

    name = 'springs'
    scene_fields = list_of(table(SPRING), 'springs')
    parts = (SpringParameters, AnchoredSpringParameters)

    @classmethod
    def resolve(cls, settings, key, bodies):
        """Return a :class:`SpringSpec` per checked entry, ends made indices into ``bodies``.

        ``bodies`` are the scene's BodySpecs. None for an empty list: it lists no spring.
        """
        return resolve_springs(settings, key, bodies) or None

    @classmethod
    def from_settings(cls, bodies, settings):
        """Return the springs on ``bodies`` (RigidBodies) of ``settings``, SpringSpecs."""
        return cls(bodies, settings)

    def __init__(self, bodies, specs):
        super().__init__(bodies)
        body = np.array([s.body for s in specs], dtype=np.int64)
        other = np.array([-1 if s.other is None else s.other for s in specs], dtype=np.int64)
        point = np.array([s.point for s in specs], dtype=float).reshape(-1, 3)
        other_point = np.array([np.zeros(3) if s.other is None else s.other_point
                                for s in specs], dtype=float).reshape(-1, 3)
        com = bodies.com_in_body
        self._parameters = SpringParameters(
            body, np.ascontiguousarray(point - com[body]),
            np.array([s.stiffness for s in specs], dtype=float),
            np.array([s.damping for s in specs], dtype=float),
            np.array([s.rest_length for s in specs], dtype=float), other,
            np.ascontiguousarray(np.where((other >= 0)[:, None],
                                          other_point - com[np.maximum(other, 0)], 0.0)),
            np.array([np.zeros(3) if s.anchor is None or s.other is not None else s.anchor
                      for s in specs], dtype=float).reshape(-1, 3))
        self._kernel_parameters = (self._parameters if np.any(other >= 0)
                                   else self._by_body(bodies.count))
        self.velocity_dependent = bool(np.any(self._parameters.damping != 0.0))
        self._inverse_mass = self._inverse_effective_mass(bodies)
        self.torqued[body] = True
        self.torqued[other[other >= 0]] = True

    @property
    def parameters(self):
        """Return the parameters the compiled kernel reads.

        :class:`AnchoredSpringParameters` when every spring ends in the world, else
        :class:`SpringParameters`.
        """
        return self._kernel_parameters

    def _by_body(self, count):
        p = self._parameters
        order = np.argsort(p.body, kind='stable')
        rows = np.column_stack((p.lever, p.anchor, p.stiffness, p.damping, p.rest))[order]
        return AnchoredSpringParameters(np.searchsorted(p.body[order], np.arange(count + 1)),
                                        np.ascontiguousarray(rows))

    def _inverse_effective_mass(self, bodies):
        """(S,) 1/kg: an upper bound on how fast each spring's ends accelerate per newton.

        A force ``f`` at lever ``r`` from a centre of mass accelerates that point by at most
        ``|f| (1/M + |r|^2 / I_min)``; a spring between bodies moves both ends.
        """
        p, smallest = self._parameters, bodies.principal_moments[0][:, 0]
        first = 1.0 / bodies.mass[p.body] + np.sum(p.lever ** 2, axis=1) / smallest[p.body]
        on_body = np.maximum(p.other, 0)
        second = (1.0 / bodies.mass[on_body]
                  + np.sum(p.other_lever ** 2, axis=1) / smallest[on_body])
        return first + np.where(p.other >= 0, second, 0.0)

    def natural_frequency(self):
        """(S,) rad/s, an upper bound on each spring's angular frequency ``sqrt(k / m_eff)``.

        Exact for a spring at the centre of mass of one body held by a fixed anchor.
        """
        return np.sqrt(self._parameters.stiffness * self._inverse_mass)

    def damping_rate(self):
        """(S,) 1/s, an upper bound on each damper's decay rate ``c / m_eff``."""
        return self._parameters.damping * self._inverse_mass

    def fastest_rate(self):
        """1/s, the fastest rate of the springs: the time step must resolve it.

        Springs sharing a body add their squared frequencies (parallel springs); a damper
        contributes its decay rate. 0 without springs.
        """
        p = self._parameters
        if not p.stiffness.size:
            return 0.0
        on_body = p.other >= 0
        ends = np.concatenate((p.body, p.other[on_body]))
        squared = self.natural_frequency() ** 2
        per_body = np.bincount(ends, weights=np.concatenate((squared, squared[on_body])))
        return float(max(np.sqrt(per_body.max()), self.damping_rate().max()))

    def potential_energy(self, snapshot):
        """``sum k (l - l0)^2 / 2``, J."""
        p = self._parameters
        lengths = spring_lengths(p, snapshot.y, np.empty(p.stiffness.size))
        return float(0.5 * np.sum(p.stiffness * (lengths - p.rest) ** 2))


@helper
def _end_position(y, body, lever, s):
    """World position of the end at ``lever[s]`` on ``body``, its ``R`` and lever ``R r``."""
    r = kin.matrix(kin.orientation(y, body))
    arm = kin.rotate(r, kin.vector(lever, s, 0))
    return (y[body, 0] + arm[0], y[body, 1] + arm[1], y[body, 2] + arm[2]), r, arm


@helper
def _end(y, model, body, lever, s):
    """World position, velocity and lever ``R r`` of the end at ``lever[s]`` on ``body``."""
    position, r, arm = _end_position(y, body, lever, s)
    inverse_mass = model.inverse_mass[body]
    omega = kin.angular_velocity(r, kin.entries(model.inertia_inv, body),
                                 kin.vector(y, body, 10))
    spin = kin.cross(omega, arm)
    velocity = (y[body, 7] * inverse_mass + spin[0], y[body, 8] * inverse_mass + spin[1],
                y[body, 9] * inverse_mass + spin[2])
    return position, velocity, arm


# Inlined: a call inside a loop keeps the caller's array references alive across it.
@helper(inline='always')
def _tension(k, c, rest, first, second, first_velocity, second_velocity):
    """Force on the first end of a spring ``k``, damper ``c``: Hooke's law plus the damper.

    3-tuple, N; scalars and tuples only, so a call passes no arrays.
    """
    d = (first[0] - second[0], first[1] - second[1], first[2] - second[2])
    dv = (first_velocity[0] - second_velocity[0], first_velocity[1] - second_velocity[1],
          first_velocity[2] - second_velocity[2])
    if rest > 0.0:
        length = math.sqrt(kin.dot(d, d))
        # A scene refuses both ends at one point; a pass through it reads as no direction.
        scale = 1.0 / length if length > 0.0 else 1.0
        u = (d[0] * scale, d[1] * scale, d[2] * scale)
        along = -(k * (length - rest) + c * kin.dot(dv, u))
        return (along * u[0], along * u[1], along * u[2])
    return (-k * d[0] - c * dv[0], -k * d[1] - c * dv[1], -k * d[2] - c * dv[2])


@helper
def _add(force, torque, body, f, arm):
    """Add the force ``f`` acting at lever ``arm`` (world) on ``body``."""
    moment = kin.cross(arm, f)
    for k in range(3):
        force[body, k] += f[k]
        torque[body, k] += moment[k]


@kernel_for(SpringParameters)
@helper
def spring_wrench(p, y, time, model, force, torque):
    """Add every spring's force and torque on its bodies to ``force``, ``torque`` (N, 3)."""
    for s in range(p.body.size):
        first, first_velocity, arm = _end(y, model, p.body[s], p.lever, s)
        other = p.other[s]
        if other >= 0:
            second, second_velocity, other_arm = _end(y, model, other, p.other_lever, s)
        else:
            second, second_velocity = kin.vector(p.anchor, s, 0), (0.0, 0.0, 0.0)
            other_arm = second_velocity
        f = _tension(p.stiffness[s], p.damping[s], p.rest[s], first, second, first_velocity,
                     second_velocity)
        _add(force, torque, p.body[s], f, arm)
        if other >= 0:
            _add(force, torque, other, (-f[0], -f[1], -f[2]), other_arm)


@body_kernel_for(AnchoredSpringParameters)
@helper(inline='always')
def anchored_spring_wrench(p, i, x, q, momentum, big_l, time, model):
    """Force and torque (3-tuples) of the springs holding body ``i`` to the world.

    The same arithmetic as :func:`spring_wrench`, body ``i``'s springs in the scene's order.
    """
    force = torque = (0.0, 0.0, 0.0)
    start, end = p.first[i], p.first[i + 1]
    if start == end:
        return force, torque
    rows = p.rows
    r = kin.matrix(q)
    omega = kin.angular_velocity(r, kin.entries(model.inertia_inv, i), big_l)
    inverse_mass = model.inverse_mass[i]
    for s in range(start, end):
        arm = kin.rotate(r, kin.vector(rows, s, 0))
        spin = kin.cross(omega, arm)
        velocity = (momentum[0] * inverse_mass + spin[0], momentum[1] * inverse_mass + spin[1],
                    momentum[2] * inverse_mass + spin[2])
        f = _tension(rows[s, 6], rows[s, 7], rows[s, 8], kin.add(x, arm),
                     kin.vector(rows, s, 3), velocity, (0.0, 0.0, 0.0))
        force, torque = kin.add(force, f), kin.add(torque, kin.cross(arm, f))
    return force, torque


@kernel
def spring_lengths(p, y, out):
    """Length of each spring (S,), m, at the packed state ``y``, into ``out``."""
    for s in range(p.body.size):
        first = _end_position(y, p.body[s], p.lever, s)[0]
        if p.other[s] >= 0:
            second = _end_position(y, p.other[s], p.other_lever, s)[0]
        else:
            second = kin.vector(p.anchor, s, 0)
        d = (first[0] - second[0], first[1] - second[1], first[2] - second[2])
        out[s] = math.sqrt(kin.dot(d, d))
    return out
