# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""IMUs mounted on bodies: what they read (their scene entry: :mod:`.imu_spec`).

An IMU at body-frame point p of a body with centre of mass c reads, in the body's axes,

- the angular velocity omega;
- the specific force at the point, f = a_c + alpha x r + omega x (omega x r) - g, with
  r = R (p - c), a_c = F / M and alpha from Euler's equations, I alpha = tau - omega x I omega,

where F and tau are the net force and the torque about c at the current state, time and
held inputs (:meth:`rigid_sim.core.world.World.net_wrench`), never differences of
velocities. A body at rest on the ground or hanging from a spring thus reads +g upwards; a
falling one reads 0. A magnetometer reads the scene's field B (world axes) in the body's
axes, R^T B. Readings are taken at the first tick at or after each multiple of the
IMU's period, of simulated time, and get noise from :mod:`rigid_sim.core.imu_noise`.
"""
import math
from dataclasses import dataclass

import numpy as np

from rigid_sim.core.effects.gravity import gravity_of
from rigid_sim.core.imu_kinematics import readings
from rigid_sim.core.imu_noise import NoisySensor
from rigid_sim.core.imu_spec import ImuSpec, parse_imus
from rigid_sim.core.state import ANGULAR_MOMENTUM, ORIENTATION

__all__ = ['ImuSpec', 'Imus', 'Readings', 'build_imus', 'parse_imus']
# A reading is due when simulated time is within this fraction of a period of its time, so
# that sums of binary-inexact time steps do not push a reading to the next tick.
DUE_SLACK = 1e-9
STREAMS = 3   # noise streams per IMU: gyro, accel, magnetometer


def build_imus(scene_bodies, bodies, gravity, magnetic_field=None):
    """Build the :class:`Imus` of the scene's bodies that declare any.

    Parameters
    ----------
    scene_bodies : sequence of BodySpec
        The scene's bodies; ``imus`` is a tuple of ImuSpec, empty for none.
    bodies : RigidBodies
        The same bodies, as the world holds them.
    gravity : (3,) float or None
        The scene's gravitational acceleration, m/s^2, world frame.
    magnetic_field : (3,) float or None
        The scene's magnetic field, T, world frame (None: no magnetometer may read it).

    Returns
    -------
    Imus or None
        None when no body declares an IMU.
    """
    mounted = [(index, spec) for index, body in enumerate(scene_bodies) for spec in body.imus]
    if not mounted:
        return None
    return Imus(bodies, mounted, np.zeros(3) if gravity is None else np.asarray(gravity),
                np.zeros(3) if magnetic_field is None else np.asarray(magnetic_field))


def scene_imus(scene, world):
    """Return the :class:`Imus` of ``scene`` on ``world`` (the World built from it), or None.

    Their gravity is that of the world's Gravity effect (none when the scene lists no
    gravity); the magnetic field their magnetometers read is the scene's.
    """
    return build_imus(scene.bodies, world.bodies, gravity_of(world.effects),
                      scene.magnetic_field)


@dataclass(frozen=True)
class Readings:
    """What K IMUs read at one time; rows in the order of the ``which`` asked for."""

    time: float                  # s
    which: list                  # positions among the Imus
    angular_velocity: np.ndarray  # (K, 3) rad/s, body axes
    specific_force: np.ndarray    # (K, 3) m/s^2, body axes
    orientation: np.ndarray       # (K, 4) (x, y, z, w), body to world; 0 where not published
    magnetic_field: np.ndarray    # (K, 3) T, body axes (read by the magnetometers only)


class Imus:
    """Every IMU of a world: where it is, when it reads next, and its noise.

    Parameters
    ----------
    bodies : RigidBodies
    mounted : list of (body index, ImuSpec)
        A body's IMUs in the order of its scene entry.
    gravity : (3,) m/s^2, world axes
    magnetic_field : (3,) T, world axes
    """

    def __init__(self, bodies, mounted, gravity, magnetic_field):
        self.bodies = [index for index, _ in mounted]
        self.specs = [spec for _, spec in mounted]
        self._mass = bodies.mass[self.bodies]
        self._inertia = bodies.inertia_body[self.bodies]
        self._inertia_inv = bodies.model.inertia_inv[self.bodies]
        self._lever = np.array([spec.point for spec in self.specs]) - bodies.com_in_body[
            self.bodies]
        self._gravity = np.asarray(gravity, dtype=float)
        self._blind = np.array([not spec.orientation for spec in self.specs])
        # Without a magnetometer the field reads zero, as the Readings say.
        self._field = (np.asarray(magnetic_field, dtype=float)
                       if any(spec.magnetometer for spec in self.specs) else np.zeros(3))
        self._next = np.zeros(len(mounted))      # s, when each reads next
        self._last = np.full(len(mounted), math.nan)
        self._sensors = []
        self.restart()

    def restart(self):
        """Back to time 0: every IMU due at once, its noise drawn again from its seed."""
        self._next[:] = 0.0
        self._last[:] = math.nan
        self._sensors = []
        for k, (body, spec) in enumerate(zip(self.bodies, self.specs)):
            # Streams from the seed and the body, so that two IMUs with the same seed on
            # different bodies draw independent noise; the j-th IMU of a body takes the
            # j-th run of STREAMS children, so a body's first IMU draws as it always has.
            j = self.bodies[:k].count(body)
            seeds = np.random.SeedSequence([spec.seed, body]).spawn(STREAMS * (j + 1))
            self._sensors.append([None if noise is None
                                  else NoisySensor(noise, np.random.default_rng(seed))
                                  for noise, seed in zip((spec.gyro, spec.accel, spec.mag),
                                                         seeds[STREAMS * j:])])

    def due(self, time):
        """Positions of the IMUs that read at ``time`` (s); their next times move on."""
        which = []
        for k, spec in enumerate(self.specs):
            if spec.rate is None:
                which.append(k)
            elif time >= self._next[k] - DUE_SLACK / spec.rate:
                which.append(k)
                self._next[k] = (math.floor(time * spec.rate + DUE_SLACK) + 1) / spec.rate
        return which

    def read(self, world, which):
        """:class:`Readings` of the IMUs ``which`` at the world's current state, with noise."""
        exact = self.exact(world, which)
        for row, k in enumerate(which):
            interval = 0.0 if math.isnan(self._last[k]) else world.time - self._last[k]
            self._last[k] = world.time
            for sensor, values in zip(self._sensors[k], (
                    exact.angular_velocity, exact.specific_force, exact.magnetic_field)):
                if sensor is not None:
                    values[row] = sensor.read(values[row], interval)
        return exact

    def exact(self, world, which):
        """Noise-free :class:`Readings` of the IMUs ``which`` (see the module text)."""
        bodies = [self.bodies[k] for k in which]
        y = world.y[bodies]
        force, torque = world.net_wrench()
        omega, specific_force, field = (np.empty((len(bodies), 3)) for _ in range(3))
        readings(np.ascontiguousarray(y[:, ORIENTATION]),
                 np.ascontiguousarray(y[:, ANGULAR_MOMENTUM]), force[bodies], torque[bodies],
                 self._inertia[which], self._inertia_inv[which], self._mass[which],
                 self._lever[which], self._gravity, self._field, omega, specific_force, field)
        orientation = y[:, ORIENTATION].copy()
        orientation[self._blind[which]] = 0.0
        return Readings(world.time, list(which), omega, specific_force, orientation, field)
