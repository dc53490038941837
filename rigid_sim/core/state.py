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

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import kernel
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
        Quaternion (x, y, z, w), body to world; normalised here.
    linear_velocity : (N, 3) float
        Velocity of the body-frame origin, world, m/s.
    angular_velocity : (N, 3) float
        World axes, rad/s.
    """
    q = np.asarray(orientation, dtype=float).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=1)[:, None]
    return packed_rows(bodies, slice(None), origin, q, linear_velocity,
                       np.asarray(angular_velocity, dtype=float).reshape(-1, 3))


def packed_rows(bodies, which, origin, orientation, velocity, angular_velocity):
    """Packed rows (K, 13) of the bodies ``which`` selects, their frames' poses and twists given.

    ``x = o + R c``, ``P = M (v_o + omega x R c)``, ``L = R I_body R^T omega``.

    Parameters
    ----------
    bodies : RigidBodies
        Their masses, inertias and centres of mass.
    which : slice or (K,) int
        The bodies, as an index into ``bodies``' arrays.
    origin, orientation, velocity, angular_velocity : (K, 3), (K, 4), (K, 3), (K, 3) float
        Body-frame origin (world, m), unit quaternion (x, y, z, w, body to world; stored as
        given), origin's velocity (world, m/s), angular velocity (world, rad/s).
    """
    turn = Rotation.from_quat(orientation)
    # Rotation.apply refuses read-only arrays, as a caller's broadcast_to views are.
    offset = turn.apply(np.array(bodies.com_in_body[which], dtype=float))
    spin_body = turn.inv().apply(np.array(angular_velocity, dtype=float))
    rows = np.empty((len(offset), STATE_WIDTH))
    rows[:, POSITION] = origin + offset
    rows[:, ORIENTATION] = orientation
    rows[:, LINEAR_MOMENTUM] = (bodies.mass[which][:, None]
                                * (velocity + np.cross(angular_velocity, offset)))
    rows[:, ANGULAR_MOMENTUM] = turn.apply(np.einsum('nij,nj->ni', bodies.inertia_body[which],
                                                     spin_body))
    return rows


@kernel
def body_frames(y, inertia_inv, inverse_mass, com_in_body, out):
    """Fill ``out`` (N, 19) with each body frame's pose and twist in the packed state ``y``.

    A row is ``[o, q, v_o, omega, R^T v_o, R^T omega]``: the frame origin ``o = x - R c``
    (world, m), the orientation (x, y, z, w), the origin's velocity ``v_o = P / M - omega x
    R c`` and the angular velocity in world axes (m/s, rad/s), then both in body axes.
    ``inertia_inv`` (N, 3, 3), ``inverse_mass`` (N,) and ``com_in_body`` (N, 3) are the
    static model's (:class:`RigidBodies`).
    """
    for i in range(y.shape[0]):
        x, q, momentum, big_l = kin.body_state(y, i)
        r = kin.matrix(q)
        spin = kin.body_angular_velocity(r, kin.entries(inertia_inv, i), big_l)
        omega = kin.rotate(r, spin)   # kin.angular_velocity, sharing its body-axes value
        offset = kin.rotate(r, kin.vector(com_in_body, i, 0))
        velocity = kin.plus_scaled(kin.cross(offset, omega), inverse_mass[i], momentum)
        kin.store(out, i, 0, kin.plus_scaled(x, -1.0, offset))
        kin.store(out, i, 3, q)
        kin.store(out, i, 7, velocity)
        kin.store(out, i, 10, omega)
        kin.store(out, i, 13, kin.rotate_inverse(r, velocity))
        kin.store(out, i, 16, spin)
    return out


def frame_rows(bodies, y, which=slice(None)):
    """Rows (K, 19) of :func:`body_frames` for the bodies ``which`` (a slice) of state ``y``."""
    model = bodies.model
    rows = y[which]
    return body_frames(np.ascontiguousarray(rows, dtype=float), model.inertia_inv[which],
                       model.inverse_mass[which], np.ascontiguousarray(bodies.com_in_body[which]),
                       np.empty((rows.shape[0], 19)))


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
    def frames(self):
        """(N, 19) pose and twist of each body frame (:func:`frame_rows`)."""
        return frame_rows(self.bodies, self.y)

    @cached_property
    def velocity(self):
        """(N, 3) centre-of-mass velocity ``v = P / M``, world, m/s."""
        return (self.y.T[LINEAR_MOMENTUM] * self.bodies.inverse_mass).T

    @property
    def angular_velocity(self):
        """(N, 3) angular velocity, world, rad/s (see :func:`kinematics.angular_velocity`)."""
        return self.frames[:, 10:13]

    def point_world(self, body_index, point_body):
        """World position of body-frame points: ``x + R (p - c)``, (K,) and (K, 3) -> (K, 3)."""
        lever = point_body - self.bodies.com_in_body[body_index]
        turned = Rotation.from_quat(self.y[body_index, ORIENTATION]).apply(lever)
        return self.y[body_index, POSITION] + turned

    def point_velocity(self, body_index, point_world):
        """Velocity of material points: ``v + omega x (p - x)``, (K,), (K, 3) -> (K, 3)."""
        lever = point_world - self.y[body_index, POSITION]
        return self.velocity[body_index] + np.cross(self.angular_velocity[body_index], lever)

    def body_frame_pose(self):
        """Origin (N, 3) and orientation (N, 4) of each body frame."""
        return self.frames[:, 0:3], self.frames[:, 3:7]

    def body_frame_twist(self):
        """Velocity of each body-frame origin and angular velocity, world axes, (N, 3) each."""
        return self.frames[:, 7:10], self.frames[:, 10:13]

    def kinetic_energy(self):
        """(N,) ``P.P / 2M + omega.L / 2``, J."""
        momentum, spin = self.y[:, LINEAR_MOMENTUM], self.y[:, ANGULAR_MOMENTUM]
        translational = np.einsum('ni,ni->n', momentum, momentum) / self.bodies.mass
        return 0.5 * (translational + np.einsum('ni,ni->n', self.angular_velocity, spin))
