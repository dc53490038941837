# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Rigid bodies as arrays: the static model, the packed Baraff state and what derives from it.

The static model (masses, inertias, centre-of-mass offsets) is kept apart from the dynamic
state ``y`` (N, 13) = [x, q, P, L] so that integrators copy and combine only what changes.
See docs/conventions.md for the layout and frames.
"""
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core import kinematics, rotation
from rigid_sim.core.inertia import check_inertia

POSITION = slice(0, 3)
ORIENTATION = slice(3, 7)
LINEAR_MOMENTUM = slice(7, 10)
ANGULAR_MOMENTUM = slice(10, 13)
STATE_WIDTH = 13


class Model(NamedTuple):
    """The static model the compiled kernels read: arrays over the N bodies."""

    inverse_mass: np.ndarray   # (N,) 1/kg
    inertia_inv: np.ndarray    # (N, 3, 3) ``I_body^-1``, body axes, 1/(kg m^2)
    moments: np.ndarray        # (N, 3) principal moments, ascending, kg m^2
    principal: np.ndarray      # (N, 4) quaternion (x, y, z, w), principal axes to body axes
    mass: np.ndarray           # (N,) kg
    gyration: np.ndarray       # (N,) m, radius of gyration sqrt(trace(I_body) / M): a size


@dataclass(frozen=True)
class RigidBodies:
    """Static properties of N bodies, in scene order."""

    names: tuple          # (N,) str, unique
    mass: np.ndarray      # (N,) kg
    inertia_body: np.ndarray  # (N, 3, 3) kg m^2 about the centre of mass, body axes
    com_in_body: np.ndarray   # (N, 3) m, centre of mass in body-frame coordinates

    def __post_init__(self):
        count = len(self.names)
        shapes = {'mass': ((count,), self.mass),
                  'inertia_body': ((count, 3, 3), self.inertia_body),
                  'com_in_body': ((count, 3), self.com_in_body)}
        if count == 0:
            raise ValueError('a world needs at least one body')
        for field, (shape, value) in shapes.items():
            if np.shape(value) != shape:
                raise ValueError(f'{field} must have shape {shape} for {count} bodies, got '
                                 f'{np.shape(value)}')
        if not np.all(np.isfinite(self.com_in_body)):
            raise ValueError(f'centres of mass must be finite, got {self.com_in_body}')
        mass = np.asarray(self.mass, dtype=float)
        if not np.all(np.isfinite(mass) & (mass > 0.0)):
            raise ValueError(f'masses must be finite and positive, got {mass}')
        for name, inertia in zip(self.names, self.inertia_body):
            try:
                check_inertia(inertia)
            except ValueError as error:
                raise ValueError(f'body {name!r}: {error}') from None
        if len(set(self.names)) != len(self.names):
            raise ValueError(f'body names must be unique, got {list(self.names)}')

    @property
    def count(self):
        """Return the number of bodies N."""
        return len(self.names)

    @cached_property
    def inertia_body_inv(self):
        """(N, 3, 3) inverse body inertia, ``I_body^-1``."""
        return np.linalg.inv(self.inertia_body)

    @cached_property
    def model(self):
        """Return the :class:`Model` (static arrays for the kernels) of these bodies."""
        moments, axes = self.principal_moments
        mass = np.asarray(self.mass, dtype=float)
        gyration = np.sqrt(np.trace(self.inertia_body, axis1=1, axis2=2) / mass)
        return Model(np.ascontiguousarray(self.inverse_mass),
                     np.ascontiguousarray(self.inertia_body_inv), np.ascontiguousarray(moments),
                     np.ascontiguousarray(Rotation.from_matrix(axes).as_quat()),
                     np.ascontiguousarray(mass), np.ascontiguousarray(gyration))

    @cached_property
    def inverse_mass(self):
        """(N,) ``1 / M``, 1/kg."""
        return 1.0 / np.asarray(self.mass, dtype=float)

    @cached_property
    def principal_moments(self):
        """(N, 3) principal moments and (N, 3, 3) body-from-principal rotations.

        ``eigh``: symmetric input, orthonormal eigenvectors, best precision.
        """
        moments, axes = np.linalg.eigh(self.inertia_body)
        # A proper rotation (det +1) so the axes can become a quaternion.
        axes[:, :, 2] *= np.sign(np.linalg.det(axes))[:, None]
        return moments, axes

    def index(self, name):
        """Scene index of the body called ``name``; KeyError lists the known names."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f'unknown body {name!r}; bodies are {list(self.names)}') from None


def initial_state(bodies, origin, orientation, linear_velocity, angular_velocity):
    """Packed state (N, 13) from the pose and twist of each body frame.

    Parameters
    ----------
    bodies : RigidBodies
        The static model: masses, inertias and centre-of-mass offsets.
    origin : (N, 3) float
        Body-frame origin, world, m.
    orientation : (N, 4) float
        Quaternion (x, y, z, w), body to world.
    linear_velocity : (N, 3) float
        Velocity of the body-frame origin, world, m/s.
    angular_velocity : (N, 3) float
        World axes, rad/s.
    """
    q = rotation.normalize(np.asarray(orientation, dtype=float).reshape(-1, 4))
    matrices = rotation.to_matrix(q)
    com_offset = rotation.rotate(matrices, bodies.com_in_body)
    omega = np.asarray(angular_velocity, dtype=float).reshape(-1, 3)
    velocity_com = linear_velocity + np.cross(omega, com_offset)
    inertia_world = matrices @ bodies.inertia_body @ matrices.transpose(0, 2, 1)
    y = np.empty((bodies.count, STATE_WIDTH))
    y[:, POSITION] = np.asarray(origin, dtype=float) + com_offset
    y[:, ORIENTATION] = q
    y[:, LINEAR_MOMENTUM] = bodies.mass[:, None] * velocity_com
    y[:, ANGULAR_MOMENTUM] = rotation.rotate(inertia_world, omega)
    return y


class Snapshot:
    """Kinematics of every body at one instant, each quantity computed once when first asked.

    Outputs, energies and diagnostics share one snapshot, so ``R`` and ``omega`` are not
    recomputed by every reader.

    Parameters
    ----------
    bodies : RigidBodies
        The bodies the state belongs to.
    y : (N, 13) float
        Packed state [x, q, P, L], world frame.
    time : float
        Simulated time of the state, s.
    """

    def __init__(self, bodies, y, time):
        self.bodies = bodies
        self.y = np.ascontiguousarray(y, dtype=float)
        self.time = time

    @cached_property
    def rotation_rows(self):
        """(3, 3, N) ``R``, body to world, one row per matrix entry."""
        return rotation.matrix_rows(self.y.T[ORIENTATION])

    @property
    def rotation(self):
        """(N, 3, 3) ``R``, body to world (a view of ``rotation_rows``)."""
        return self.rotation_rows.transpose(2, 0, 1)

    @cached_property
    def velocity(self):
        """(N, 3) centre-of-mass velocity ``v = P / M``, world, m/s."""
        return (self.y.T[LINEAR_MOMENTUM] * self.bodies.inverse_mass).T

    @cached_property
    def angular_velocity(self):
        """(N, 3) angular velocity, world, rad/s (see :func:`kinematics.angular_velocity`)."""
        return kinematics.angular_velocities(self.y, self.bodies.model.inertia_inv,
                                             np.empty((self.bodies.count, 3)))

    @cached_property
    def com_offset(self):
        """(N, 3) ``R c``: from the body-frame origin to the centre of mass, world, m."""
        return rotation.rotate_rows(self.rotation_rows, self.bodies.com_in_body.T).T

    def point_world(self, body_index, point_body):
        """World position of body-frame points: ``x + R (p - c)``, (K,) and (K, 3) -> (K, 3)."""
        lever = (point_body - self.bodies.com_in_body[body_index]).T
        turned = rotation.rotate_rows(self.rotation_rows[:, :, body_index], lever)
        return self.y[body_index, POSITION] + turned.T

    def point_velocity(self, body_index, point_world):
        """Velocity of material points: ``v + omega x (p - x)``, (K,), (K, 3) -> (K, 3)."""
        lever = (point_world - self.y[body_index, POSITION]).T
        spin = rotation.cross_rows(self.angular_velocity[body_index].T, lever)
        return self.velocity[body_index] + spin.T

    def body_frame_pose(self):
        """Origin (N, 3) and orientation (N, 4) of each body frame."""
        return self.y[:, POSITION] - self.com_offset, self.y[:, ORIENTATION]

    def body_frame_twist(self):
        """Velocity of each body-frame origin and angular velocity, world axes, (N, 3) each."""
        spin = rotation.cross_rows(self.angular_velocity.T, self.com_offset.T)
        return self.velocity - spin.T, self.angular_velocity

    def kinetic_energy(self):
        """(N,) ``P.P / 2M + omega.L / 2``, J."""
        y = self.y
        translational = 0.5 * np.sum(y[:, LINEAR_MOMENTUM] ** 2, axis=1) / self.bodies.mass
        rotational = 0.5 * np.sum(self.angular_velocity * y[:, ANGULAR_MOMENTUM], axis=1)
        return translational + rotational
