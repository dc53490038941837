# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""IMUs mounted on bodies: what a scene declares, and what they read.

An IMU at body-frame point p of a body with centre of mass c reads, in the body's axes,

- the angular velocity omega;
- the specific force at the point, f = a_c + alpha x r + omega x (omega x r) - g, with
  r = R (p - c), a_c = F / M and alpha from Euler's equations, I alpha = tau - omega x I omega,

where F and tau are the net force and the torque about c at the current state, time and
held inputs (:meth:`rigid_sim.core.world.World.net_wrench`), never differences of
velocities. A body at rest on the ground or hanging from a spring thus reads +g upwards; a
falling one reads 0. Readings are taken at the first tick at or after each multiple of the
IMU's period, of simulated time, and get noise from :mod:`rigid_sim.core.imu_noise`.
"""
import math
from dataclasses import dataclass

import numpy as np

from rigid_sim.core.imu_kinematics import readings
from rigid_sim.core.imu_noise import NoisySensor, SensorNoise
from rigid_sim.core.scene_fields import (
    ABSENT, fields, MAX_MAGNITUDE, Mistake, non_negative, number, of_type, positive, raw, table,
    vector)
from rigid_sim.core.state import ANGULAR_MOMENTUM, ORIENTATION
from rigid_sim.core.text import shown

DEFAULT_FRAME = 'imu'   # child frame <body>/imu of an IMU placed by coordinates
NOISE = {'stddev': (non_negative, 0.0), 'bias_mean': (number, 0.0),
         'bias_stddev': (non_negative, 0.0), 'dynamic_bias_stddev': (non_negative, 0.0),
         'dynamic_bias_correlation_time': (positive, ABSENT)}
IMU = {'point': (raw, [0.0, 0.0, 0.0]), 'rate': (positive, ABSENT),
       'noise': (table({'gyro': (table(NOISE), ABSENT), 'accel': (table(NOISE), ABSENT)}),
                 ABSENT),
       'seed': (of_type(int, 'a whole number'), 0)}
# A reading is due when simulated time is within this fraction of a period of its time, so
# that sums of binary-inexact time steps do not push a reading to the next tick.
DUE_SLACK = 1e-9


@dataclass(frozen=True)
class ImuSpec:
    """One body's IMU as the scene declares it."""

    point: np.ndarray   # (3,) m, body-frame coordinates of the mount point
    frame: str          # child frame name: <body>/<frame> (a named point, or 'imu')
    rate: float         # Hz of simulated time; None: every tick
    gyro: SensorNoise   # None: exact angular velocity
    accel: SensorNoise  # None: exact specific force
    seed: int           # of this IMU's noise stream


def parse_imu(value, key, points):
    """Parse a body's ``imu`` entry into an :class:`ImuSpec`.

    ``points`` are the body's named points.

    Raises :class:`~rigid_sim.core.scene_fields.Mistake` naming the key and the reason.
    """
    imu = fields(value, key, IMU)
    point = imu['point']
    if isinstance(point, str):
        if point not in points:
            raise Mistake(f'{key}.point', f'no point named {point!r}; the body has '
                                          f'{sorted(points)} (or give [x, y, z])')
        where, frame = points[point], point
    else:
        if DEFAULT_FRAME in points:
            raise Mistake(f'{key}.point', f'the body has a point named {DEFAULT_FRAME!r}, the '
                                          'frame of an IMU given by coordinates: name it')
        where, frame = vector(point, f'{key}.point'), DEFAULT_FRAME
    # Bounded as every number of a scene is, though numpy would take any size of seed.
    if not 0 <= imu['seed'] <= MAX_MAGNITUDE:
        raise Mistake(f'{key}.seed', f'must be a whole number >= 0 and at most '
                                     f'{MAX_MAGNITUDE:g}, got {shown(imu["seed"])}')
    noise = imu.get('noise', {})
    sensors = {name: SensorNoise(**noise[name]) if name in noise else None
               for name in ('gyro', 'accel')}
    return ImuSpec(point=np.array(where, dtype=float), frame=frame, rate=imu.get('rate'),
                   seed=imu['seed'], **sensors)


def build_imus(scene_bodies, bodies, gravity):
    """Build the :class:`Imus` of the scene's bodies that declare one.

    Parameters
    ----------
    scene_bodies : sequence of BodySpec
        The scene's bodies; ``imu`` is an ImuSpec or None.
    bodies : RigidBodies
        The same bodies, as the world holds them.
    gravity : (3,) float or None
        The scene's gravitational acceleration, m/s^2, world frame.

    Returns
    -------
    Imus or None
        None when no body declares an IMU.
    """
    mounted = [(index, body.imu) for index, body in enumerate(scene_bodies)
               if body.imu is not None]
    if not mounted:
        return None
    return Imus(bodies, mounted, np.zeros(3) if gravity is None else np.asarray(gravity))


def scene_imus(scene, bodies):
    """Return the :class:`Imus` of ``scene`` on ``bodies`` (its RigidBodies), or None.

    Their gravity is the scene's (none when it lists no gravity).
    """
    gravity = scene.effects.get('gravity', {}).get('acceleration')
    return build_imus(scene.bodies, bodies, gravity)


@dataclass(frozen=True)
class Readings:
    """What K IMUs read at one time; rows in the order of the ``which`` asked for."""

    time: float                  # s
    which: list                  # positions among the Imus
    angular_velocity: np.ndarray  # (K, 3) rad/s, body axes
    specific_force: np.ndarray    # (K, 3) m/s^2, body axes
    orientation: np.ndarray       # (K, 4) (x, y, z, w), body to world


class Imus:
    """Every IMU of a world: where it is, when it reads next, and its noise.

    Parameters
    ----------
    bodies : RigidBodies
    mounted : list of (body index, ImuSpec)
    gravity : (3,) m/s^2, world axes
    """

    def __init__(self, bodies, mounted, gravity):
        self.bodies = [index for index, _ in mounted]
        self.specs = [spec for _, spec in mounted]
        self._mass = bodies.mass[self.bodies]
        self._inertia = bodies.inertia_body[self.bodies]
        self._inertia_inv = np.linalg.inv(self._inertia)
        self._lever = np.array([spec.point for spec in self.specs]) - bodies.com_in_body[
            self.bodies]
        self._gravity = np.asarray(gravity, dtype=float)
        self._next = np.zeros(len(mounted))      # s, when each reads next
        self._last = np.full(len(mounted), math.nan)
        self._sensors = []
        self.restart()

    def restart(self):
        """Back to time 0: every IMU due at once, its noise drawn again from its seed."""
        self._next[:] = 0.0
        self._last[:] = math.nan
        self._sensors = []
        for body, spec in zip(self.bodies, self.specs):
            # One stream per sensor, from the seed and the body: two IMUs with the same seed
            # on different bodies still draw independent noise.
            seeds = np.random.SeedSequence([spec.seed, body]).spawn(2)
            self._sensors.append([None if noise is None
                                  else NoisySensor(noise, np.random.default_rng(seed))
                                  for noise, seed in zip((spec.gyro, spec.accel), seeds)])

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
            gyro, accel = self._sensors[k]
            if gyro is not None:
                exact.angular_velocity[row] = gyro.read(exact.angular_velocity[row], interval)
            if accel is not None:
                exact.specific_force[row] = accel.read(exact.specific_force[row], interval)
        return exact

    def exact(self, world, which):
        """Noise-free :class:`Readings` of the IMUs ``which`` (see the module text)."""
        bodies = [self.bodies[k] for k in which]
        y = world.y[bodies]
        force, torque = world.net_wrench()
        omega, specific_force = np.empty((len(bodies), 3)), np.empty((len(bodies), 3))
        readings(np.ascontiguousarray(y[:, ORIENTATION]),
                 np.ascontiguousarray(y[:, ANGULAR_MOMENTUM]), force[bodies], torque[bodies],
                 self._inertia[which], self._inertia_inv[which], self._mass[which],
                 self._lever[which], self._gravity, omega, specific_force)
        return Readings(world.time, list(which), omega, specific_force,
                        y[:, ORIENTATION].copy())
