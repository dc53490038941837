# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Worlds built straight from the core, and references that do not use the core.

The references are physics in the tests' own terms: closed forms, and the Newton-Euler
equations integrated by DOP853 in :mod:`rigid_sim.bench.oracles` (one definition, shared
with the benchmarks). Quaternions are ``(x, y, z, w)``, body to world.
Imported by the test modules as ``import physics_cases`` (pytest puts ``test/`` on sys.path).
"""
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.bench import oracles
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World

# A generic orientation: no body axis along a world axis, so no term of a test vanishes.
TILT = Rotation.from_rotvec([0.3, -0.5, 0.8])
ADAPTIVE_INTERVAL = 0.05   # s between calls to an adaptive method; it picks its own substeps
ADAPTIVE_TOLERANCE = 1e-10  # asked of adaptive methods in accuracy tests
ADAPTIVE_ALLOWED = 1e-8     # error allowed them: global error builds up to ~10x the local target
# Global error of a method of order p over a few periods: K (rate dt)^p, with K of order
# one; the bound leaves room for the worst method of the registry on these problems.
ORDER_ERROR_CONSTANT = 20.0
FIXED_STEP = sorted(name for name, cls in REGISTRY.items() if not cls.adaptive)
# Methods accurate enough for tight comparisons at dt = 1e-3: order >= 4 or error-controlled.
ACCURATE = sorted(name for name, cls in REGISTRY.items() if cls.adaptive or cls.order >= 4)
# One box in free flight, x = X0 + V0 t, for the lockstep tests over ROS (in the test kit
# and as a process), stepped by FLIGHT_STEP, exact in binary: simulated times add up exactly.
FLIGHT_STEP = 1 / 64
FLIGHT_X0, FLIGHT_V0 = np.array([1.0, -2.0, 0.5]), np.array([0.5, 0.25, -1.0])
FLYING_BOX = f"""
bodies:
  - name: box
    shape: {{type: box, size: [0.4, 0.2, 0.1]}}
    mass: 2.0
    pose: {{position: {FLIGHT_X0.tolist()}}}
    twist: {{linear: {FLIGHT_V0.tolist()}}}
"""


def make_bodies(mass, inertia, com_in_body=None):
    """Bodies named ``b0, b1, ...``.

    Parameters
    ----------
    mass : (N,) float
        kg.
    inertia : (N, 3, 3) float
        About the centre of mass, body axes, kg m^2.
    com_in_body : (N, 3) float, optional
        Centre of mass in body-frame coordinates, m (zeros if None).
    """
    mass = np.atleast_1d(np.asarray(mass, dtype=float))
    inertia = np.asarray(inertia, dtype=float).reshape(-1, 3, 3)
    com = np.zeros((mass.size, 3)) if com_in_body is None else com_in_body
    names = tuple(f'b{i}' for i in range(mass.size))
    return RigidBodies(names, mass, inertia, np.asarray(com, dtype=float).reshape(-1, 3))


def make_world(bodies, origin, orientation, velocity, angular_velocity, effects=(),
               integrator='rk4', tolerance=1e-6, auto_substep=False, inputs=None):
    """World from the pose and twist of each body frame, (N, 3) / (N, 4), world axes.

    Sub-stepping (by bounds and by error estimate) is off by default: these cases measure
    the bare methods (orders, errors).
    ``inputs`` are the world's held wrenches (AppliedWrenches), if any.
    """
    initial = initial_state(bodies, np.reshape(origin, (-1, 3)), np.reshape(orientation, (-1, 4)),
                            np.reshape(velocity, (-1, 3)), np.reshape(angular_velocity, (-1, 3)))
    return World(bodies, initial, effects, integrator=integrator, tolerance=tolerance,
                 auto_substep=auto_substep, inputs=inputs,
                 error_control=auto_substep)


def advance(world, dt, duration):
    """Step ``world`` by ``dt`` until ``duration`` seconds have passed; returns the world."""
    steps = int(round(duration / dt))
    assert abs(steps * dt - duration) < 1e-9 * max(duration, 1.0), 'dt must divide duration'
    for _ in range(steps):
        world.step(dt)
    return world


def step_for(name, fixed_dt):
    """``fixed_dt`` for fixed-step methods; adaptive ones are asked for ADAPTIVE_INTERVAL."""
    return ADAPTIVE_INTERVAL if REGISTRY[name].adaptive else fixed_dt


def allowed_error(name, rate, dt):
    """Relative error allowed ``name`` on a problem of fastest rate ``rate`` (1/s) at step dt."""
    cls = REGISTRY[name]
    return ADAPTIVE_ALLOWED if cls.adaptive else ORDER_ERROR_CONSTANT * (rate * dt) ** cls.order


def body_angular_velocity(snapshot):
    """(N, 3) angular velocity in body axes, ``R^T omega``, rad/s."""
    return Rotation.from_quat(snapshot.y[:, 3:7]).inv().apply(snapshot.angular_velocity)


def rotation_error(q, q_reference):
    """Angle, rad, of the rotation taking ``q_reference`` to ``q``, (..., 4) each."""
    return (Rotation.from_quat(q_reference).inv() * Rotation.from_quat(q)).magnitude()


@dataclass(frozen=True)
class SingleBody:
    """One body, optionally on a zero-rest-length spring from a body point to a world anchor.

    Spring force ``-k d - c d'`` with ``d`` the point minus the anchor; plus ``M g``.
    """

    mass: float                      # kg
    inertia: np.ndarray              # (3, 3) kg m^2, about the centre of mass, body axes
    lever: np.ndarray = field(default_factory=lambda: np.zeros(3))   # com to point, body, m
    anchor: np.ndarray = field(default_factory=lambda: np.zeros(3))  # world, m
    stiffness: float = 0.0           # N/m
    damping: float = 0.0             # N s/m
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(3))  # m/s^2

    def wrench(self, time, x, v, q, omega_body):
        """Return the spring's and gravity's world force (3,) and body torque (3,)."""
        world_from_body = oracles.world_from_body(q)
        lever = world_from_body @ self.lever
        point_velocity = v + np.cross(world_from_body @ omega_body, lever)
        spring = -self.stiffness * (x + lever - self.anchor) - self.damping * point_velocity
        torque_body = np.cross(self.lever, world_from_body.T @ spring)
        return spring + self.mass * self.gravity, torque_body

    def reference(self, x0, v0, q0, omega_body0, times):
        """Return the DOP853 solution at ``times`` (T,): x, v (T, 3), q (T, 4), omega_b (T, 3)."""
        return oracles.reference_motion(self.mass, self.inertia, (x0, v0, q0, omega_body0),
                                        times, self.wrench)
