# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Linear springs with dampers between body points and world anchors or other bodies.

Each spring pulls its two attachment points together with
``f = -(k (l - l0) + c dl/dt) u`` along the unit vector ``u`` from the second end to the
first; the torque on a body is ``(p - x) x f``. With ``l0 = 0`` the force is the full vector
``-k d - c d'`` and stays defined when the points meet.
"""
from dataclasses import dataclass

import numpy as np
from scipy import sparse

from rigid_sim.core.state import POSITION


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


class Springs:
    """All springs of a scene, evaluated together."""

    def __init__(self, bodies, specs):
        self._body = np.array([s.body for s in specs], dtype=int)
        self._point = np.array([s.point for s in specs], dtype=float).reshape(-1, 3)
        self._stiffness = np.array([s.stiffness for s in specs], dtype=float)
        self._damping = np.array([s.damping for s in specs], dtype=float)
        self._rest = np.array([s.rest_length for s in specs], dtype=float)
        to_body = np.array([s.other is not None for s in specs], dtype=bool)
        # Springs to the world get a dummy second body 0; their second end is masked below.
        self._to_body = to_body
        self._other = np.array([s.other if s.other is not None else 0 for s in specs], dtype=int)
        self._other_point = np.array(
            [s.other_point if s.other is not None else np.zeros(3) for s in specs],
            dtype=float).reshape(-1, 3)
        self._anchor = np.array(
            [s.anchor if s.other is None else np.zeros(3) for s in specs],
            dtype=float).reshape(-1, 3)
        self.velocity_dependent = bool(np.any(self._damping != 0.0))
        self._inverse_mass = self._inverse_effective_mass(bodies)
        self.torqued = np.zeros(bodies.count, dtype=bool)
        self.torqued[self._body] = True
        self.torqued[self._other[to_body]] = True
        # Incidence (N, E) of the E spring ends on the bodies: one sparse product sums every
        # end's wrench into its body (np.add.at took ~18x as long at 1000 bodies).
        ends = np.concatenate((self._body, self._other[to_body]))
        self._incidence = sparse.csr_array(
            (np.ones(ends.size), (ends, np.arange(ends.size))), shape=(bodies.count, ends.size))
        self._end_body = ends
        self._end_point = np.concatenate((self._point, self._other_point[to_body]))

    def _inverse_effective_mass(self, bodies):
        """(S,) 1/kg: an upper bound on how fast each spring's ends accelerate per newton.

        A force ``f`` at lever ``r`` from a centre of mass accelerates that point by at most
        ``|f| (1/M + |r|^2 / I_min)``; a spring between bodies moves both ends.
        """
        moments = bodies.principal_moments[0]

        def end(body, point):
            lever = point - bodies.com_in_body[body]
            return 1.0 / bodies.mass[body] + np.sum(lever ** 2, axis=1) / moments[body, 0]

        second = np.where(self._to_body, end(self._other, self._other_point), 0.0)
        return end(self._body, self._point) + second

    def natural_frequency(self):
        """(S,) rad/s, an upper bound on each spring's angular frequency ``sqrt(k / m_eff)``.

        Exact for a spring at the centre of mass of one body held by a fixed anchor.
        """
        return np.sqrt(self._stiffness * self._inverse_mass)

    def damping_rate(self):
        """(S,) 1/s, an upper bound on each damper's decay rate ``c / m_eff``."""
        return self._damping * self._inverse_mass

    def fastest_rate(self):
        """1/s, the fastest rate of the springs: the time step must resolve it.

        Springs sharing a body add their squared frequencies (parallel springs); a damper
        contributes its decay rate. 0 without springs.
        """
        if not self._stiffness.size:
            return 0.0
        ends = np.concatenate((self._body, self._other[self._to_body]))
        squared = self.natural_frequency() ** 2
        per_body = np.bincount(ends, weights=np.concatenate((squared, squared[self._to_body])))
        return float(max(np.sqrt(per_body.max()), self.damping_rate().max()))

    def _ends(self, snapshot):
        """Return the positions of the spring ends on bodies, and of both ends of each spring.

        Returns the world positions (E, 3) of the E ends on bodies (first ends, then second ends on
        bodies), and the first and second ends' positions and velocities (S, 3) each.
        """
        points = snapshot.point_world(self._end_body, self._end_point)
        velocities = snapshot.point_velocity(self._end_body, points)
        count, on_body = self._body.size, self._to_body
        second, second_velocity = self._anchor.copy(), np.zeros_like(self._anchor)
        second[on_body], second_velocity[on_body] = points[count:], velocities[count:]
        return points, (points[:count], velocities[:count], second, second_velocity)

    def _tension(self, snapshot):
        """Force on the first end (S, 3), and the ends (E, 3), from Hooke's law plus damper."""
        points, (first, first_velocity, second, second_velocity) = self._ends(snapshot)
        separation = first - second
        relative_velocity = first_velocity - second_velocity
        length = np.linalg.norm(separation, axis=1)
        # Zero rest length: the force is linear in the separation and needs no direction.
        safe_length = np.where(length > 0.0, length, 1.0)
        direction = separation / safe_length[:, None]
        stretch = np.where(self._rest > 0.0, length - self._rest, 0.0)
        rate = np.sum(relative_velocity * direction, axis=1)
        along = -(self._stiffness * stretch + self._damping * rate)[:, None] * direction
        zero_rest = -(self._stiffness[:, None] * separation
                      + self._damping[:, None] * relative_velocity)
        force = np.where((self._rest > 0.0)[:, None], along, zero_rest)
        return force, points

    def accumulate(self, snapshot, force, torque):
        spring_force, points = self._tension(snapshot)
        end_force = np.concatenate((spring_force, -spring_force[self._to_body]))
        lever = points - snapshot.y[self._end_body, POSITION]
        wrench = self._incidence @ np.concatenate((end_force, np.cross(lever, end_force)),
                                                  axis=1)
        force += wrench[:, :3]
        torque += wrench[:, 3:]

    def potential_energy(self, snapshot):
        """``sum k (l - l0)^2 / 2``, J."""
        first, _, second, _ = self._ends(snapshot)[1]
        length = np.linalg.norm(first - second, axis=1)
        return float(0.5 * np.sum(self._stiffness * (length - self._rest) ** 2))
