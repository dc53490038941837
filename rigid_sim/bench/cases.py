# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Benchmark problems, each paired with an exact oracle for its state at the final time.

Every case is one body of mass 1 kg with principal moments diag(1, 2, 3) kg m^2, starting at
the identity orientation so body and world axes coincide at t = 0:

``tumbling``  torque-free, omega0 = (0.1, 5, 0.1) rad/s, near the unstable intermediate axis;
``fast_spin``  the same with omega0 = (0.1, 50, 0.1): ten times faster, ``|omega| dt`` ten
times larger at the same step;
``spring``  an underdamped spring-damper at the centre of mass (no torque) on a body in
steady spin about its major axis: closed form for both;
``offset_force``  a constant world force at a point off the centre of mass of a spinning
body: the centre of mass follows the exact parabola, the rotation is a forced rigid body.

Rotational oracles are :func:`rigid_sim.bench.oracles.reference_motion` (Euler's equations
and the quaternion kinematics by DOP853) at rtol = atol = 1e-13, once per process (cached).
"""
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.bench import oracles
from rigid_sim.core.rotation import angle_between
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.effects.springs import SpringSpec, Springs
from rigid_sim.core.safeguards import UNIT_QUATERNION_SLACK
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World

MOMENTS = np.array([1.0, 2.0, 3.0])   # kg m^2, principal moments of every test body
MASS = 1.0                            # kg
IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])
# Two decades below the smallest error the sweep resolves, so the oracle never limits it.
ORACLE_TOLERANCE = 1e-13
SPRING_STIFFNESS = (2.0 * np.pi) ** 2   # N/m: 1 Hz with 1 kg
SPRING_DAMPING = 0.2                    # N s/m: damping ratio 0.016, underdamped
SPRING_START = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))   # x0 (m), v0 (m/s)
PUSH_FORCE = np.array([0.0, 0.0, -2.0])   # N, world axes, held constant
PUSH_POINT = np.array([0.1, 0.05, 0.0])   # m, body frame (the centre of mass is the origin)


@dataclass(frozen=True)
class Reference:
    """Exact final state of a case."""

    position: np.ndarray      # (3,) centre of mass, world, m
    orientation: np.ndarray   # (4,) (x, y, z, w), body to world
    angular_velocity: np.ndarray  # (3,) world, rad/s
    energy: float             # J, the case's energy (``Case.energy``) at the final time


@dataclass(frozen=True)
class Case:
    """One benchmark problem; ``omega0`` is in body axes (= world axes at t = 0)."""

    key: str
    title: str
    duration: float       # s
    omega0: tuple         # rad/s
    steps: tuple          # fixed steps to sweep, s, largest first
    torque_free: bool     # |L| is conserved
    primary: str          # 'orientation' or 'position': the error the plot shows
    mujoco: bool          # MuJoCo runs it too (see mujoco_baseline)

    def build(self, integrator, tolerance=1e-6, estimates=True):
        """Return a fresh World running this case with the named integrator.

        ``estimates`` False: nothing reads the error estimates (``World(estimates=False)``).
        """
        bodies = RigidBodies(('body',), np.array([MASS]), np.diag(MOMENTS)[None],
                             np.zeros((1, 3)))
        start, velocity = SPRING_START if self.key == 'spring' else (np.zeros(3), np.zeros(3))
        y0 = initial_state(bodies, [start], [IDENTITY], [velocity], [self.omega0])
        # The bare method: the benchmark measures each integrator, not the safeguards.
        effects, inputs = self._effects_and_inputs(bodies)
        return World(bodies, y0, effects, integrator=integrator, tolerance=tolerance,
                     auto_substep=False, inputs=inputs, error_control=False,
                     estimates=estimates)

    def _effects_and_inputs(self, bodies):
        """Build the case's effects and its held wrenches (None: no input)."""
        if self.key == 'spring':
            spec = SpringSpec(body=0, point=np.zeros(3), stiffness=SPRING_STIFFNESS,
                              damping=SPRING_DAMPING, anchor=np.zeros(3))
            return [Springs(bodies, [spec])], None
        if self.key == 'offset_force':
            push = AppliedWrenches(bodies)
            push.hold(0, 'push', 'world_point', PUSH_FORCE, point=PUSH_POINT)
            return [], push
        return [], None

    def energy(self, world):
        """Energy this case tracks, J.

        For ``offset_force`` the conserved ``H = M v^2 / 2 + omega.L / 2 - F.(x + R r)``.
        """
        if self.key != 'offset_force':
            return world.energy()
        snapshot = world.snapshot()
        point = snapshot.point_world(np.array([0]), PUSH_POINT[None])[0]
        return float(snapshot.kinetic_energy()[0] - PUSH_FORCE @ point)

    def oracle(self):
        """Return the exact final state (cached per process)."""
        return _oracle(self)


@dataclass
class Result:
    """One (case, method, step or tolerance) measurement; errors at the final time."""

    case: str
    method: str               # registry name, or 'mujoco <integrator>'
    setting: float            # dt, s (fixed step) or tolerance (adaptive)
    adaptive: bool
    orientation_error: float  # rad
    omega_error: float        # |omega - omega_exact| / |omega_exact|
    position_error: float     # m, centre of mass
    energy_drift: float       # |E - E_exact| / |E0|
    momentum_drift: float     # ||L| - |L0|| / |L0|; NaN when torques act
    evaluations: float        # wrench evaluations; NaN for MuJoCo
    cpu_time: float           # s, median of the repeats

    def error(self, kind):
        """Return the error the plot uses for a case: 'orientation' or 'position'."""
        return getattr(self, kind + '_error')


def score(case, method, setting, adaptive, final, start, evaluations, cpu_time):
    """Compare a final state with the oracle of ``case``.

    ``final`` = (q (4,) (x, y, z, w), omega world (3,), energy J, L world (3,), x (3,));
    ``start`` = (energy J, |L| kg m^2/s) at t = 0. Non-finite errors become inf (diverged).
    """
    q, omega, energy, momentum, position = final
    reference = case.oracle()
    with np.errstate(all='ignore'):
        angle = angle_between(reference.orientation[None], np.asarray(q)[None])[0]
        omega_error = (np.linalg.norm(omega - reference.angular_velocity)
                       / np.linalg.norm(reference.angular_velocity))
        errors = [angle, omega_error, np.linalg.norm(position - reference.position),
                  abs(energy - reference.energy) / abs(start[0])]
        momentum_drift = (abs(np.linalg.norm(momentum) - start[1]) / start[1]
                          if case.torque_free else np.nan)
    if not abs(np.linalg.norm(q) - 1.0) < UNIT_QUATERNION_SLACK:
        errors[0] = np.inf   # an overflowed q normalises to zeros, at "angle 0"; the World
        # refuses such steps, MuJoCo's runs come here unchecked
    errors = [float(v) if np.isfinite(v) else np.inf for v in errors]
    if case.torque_free and not np.isfinite(momentum_drift):
        momentum_drift = np.inf
    return Result(case.key, method, setting, adaptive, *errors, float(momentum_drift),
                  evaluations, cpu_time)


def _push_wrench(time, x, v, q, omega_body):
    """Return the held world force and its torque ``r x R^T F`` in body axes."""
    return PUSH_FORCE, np.cross(PUSH_POINT, oracles.world_from_body(q).T @ PUSH_FORCE)


def _spring_motion(time):
    """Closed-form underdamped ``M x'' = -k x - c x'`` from ``SPRING_START``: x, v (3,)."""
    decay = SPRING_DAMPING / (2.0 * MASS)
    frequency = np.sqrt(SPRING_STIFFNESS / MASS - decay ** 2)
    x0, v0 = SPRING_START
    a, b = x0, (v0 + decay * x0) / frequency
    envelope = np.exp(-decay * time)
    cos, sin = np.cos(frequency * time), np.sin(frequency * time)
    x = envelope * (a * cos + b * sin)
    v = envelope * ((b * frequency - decay * a) * cos - (a * frequency + decay * b) * sin)
    return x, v


@lru_cache(maxsize=None)
def _oracle(case):
    t = case.duration
    omega0 = np.asarray(case.omega0, dtype=float)
    rotational = 0.5 * float(MOMENTS @ omega0 ** 2)
    if case.key == 'spring':
        # Steady spin about the major axis: an exact rotation at constant omega.
        x, v = _spring_motion(t)
        q = Rotation.from_rotvec(omega0 * t).as_quat()
        energy = rotational + 0.5 * MASS * v @ v + 0.5 * SPRING_STIFFNESS * x @ x
        return Reference(x, q, omega0, energy)
    wrench = _push_wrench if case.key == 'offset_force' else oracles.no_wrench
    start = (np.zeros(3), np.zeros(3), IDENTITY, omega0)
    _, _, q, omega_body = oracles.reference_motion(MASS, np.diag(MOMENTS), start, [t], wrench,
                                                   ORACLE_TOLERANCE, ORACLE_TOLERANCE)
    q = q[-1]
    omega = oracles.world_from_body(q) @ omega_body[-1]
    position = np.zeros(3)
    energy = rotational
    if case.key == 'offset_force':
        position = 0.5 * PUSH_FORCE / MASS * t ** 2
        energy -= PUSH_FORCE @ PUSH_POINT
    return Reference(position, q, omega, energy)


FIXED_STEPS = (1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3)   # s
# Torque-free cases also try steps up to the whole interval: the exact free flow is exact at
# any step, so its cost is set by how few steps a user can take, not by accuracy.
LONG_STEPS = (20.0, 4.0, 1.0, 0.2)   # s
CASES = (
    Case('tumbling', 'tumbling near the intermediate axis, omega0 = (0.1, 5, 0.1) rad/s',
         20.0, (0.1, 5.0, 0.1), LONG_STEPS + FIXED_STEPS, True, 'orientation', True),
    Case('fast_spin', 'fast spin, omega0 = (0.1, 50, 0.1) rad/s',
         20.0, (0.1, 50.0, 0.1), LONG_STEPS + FIXED_STEPS[2:] + (5e-4, 2e-4), True,
         'orientation', True),
    Case('spring', 'spring-damper at the centre of mass (1 Hz, zeta 0.016), spin about axis 3',
         10.0, (0.0, 0.0, 1.0), FIXED_STEPS, False, 'position', True),
    Case('offset_force', 'constant world force at an offset point, omega0 = (0.3, 0.2, 4)',
         10.0, (0.3, 0.2, 4.0), FIXED_STEPS, False, 'orientation', True),
)
CASES_BY_KEY = {case.key: case for case in CASES}
