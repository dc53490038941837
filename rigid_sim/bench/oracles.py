# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Reference motion of one rigid body, computed without the simulator's core.

Newton's equation for the centre of mass and Euler's equations in body axes, with the
quaternion kinematics ``dq/dt = q (omega_b, 0) / 2``, integrated by scipy's DOP853. The
state is ``s = [x, v, q, omega_b]`` (13,): centre of mass (world, m), its velocity (world,
m/s), the orientation (x, y, z, w) taking body to world axes, and the angular velocity in
body axes (rad/s).

It imports nothing from :mod:`rigid_sim.core`, so it can judge the core: the accuracy and
stability benchmarks score the integrators against it, and the tests use it as their
independent reference. It lives in the package because the benchmarks ship with it; the
tests import it from here.
"""
import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

# DOP853 rtol = atol by default: below every error the benchmarks resolve or the tests assert.
TOLERANCE = 1e-12


def quaternion_product(p, q):
    """Return the Hamilton product ``p q`` of quaternions (x, y, z, w), (4,) each."""
    pv, pw, qv, qw = p[:3], p[3], q[:3], q[3]
    return np.append(pw * qv + qw * pv + np.cross(pv, qv), pw * qw - pv @ qv)


def no_wrench(time, x, v, q, omega_body):
    """Return a zero world force and body torque: the body is free."""
    return np.zeros(3), np.zeros(3)


def rigid_body_slope(mass, inertia, wrench=no_wrench):
    """Return ``slope(time, s)``, the time derivative of the state ``s`` (13,).

    Parameters
    ----------
    mass : float
        kg.
    inertia : (3, 3) float
        About the centre of mass, body axes, kg m^2.
    wrench : callable
        ``wrench(time, x, v, q, omega_body) -> (force, torque_body)``: the net force (3,),
        world axes, N, and the torque about the centre of mass (3,), body axes, N m.
    """
    inertia = np.asarray(inertia, dtype=float)

    def slope(time, s):
        x, v, q, omega_body = s[:3], s[3:6], s[6:10], s[10:]
        force, torque_body = wrench(time, x, v, q, omega_body)
        gyroscopic = np.cross(omega_body, inertia @ omega_body)
        omega_rate = np.linalg.solve(inertia, torque_body - gyroscopic)
        q_rate = 0.5 * quaternion_product(q, np.append(omega_body, 0.0))
        return np.concatenate((v, force / mass, q_rate, omega_rate))
    return slope


def reference_motion(mass, inertia, start, times, wrench=no_wrench, rtol=TOLERANCE,
                     atol=TOLERANCE):
    """Return the state of one body at ``times``, integrated by DOP853 from time 0.

    Parameters
    ----------
    mass, inertia, wrench
        As for :func:`rigid_body_slope`.
    start : tuple of (3,), (3,), (4,), (3,) float
        ``x0``, ``v0``, ``q0`` and ``omega_body0`` at time 0, in the units of the state.
    times : (T,) float
        Increasing times, s, the last one the end of the solve.
    rtol, atol : float
        DOP853's error control; ``atol`` far below the smallest component makes it purely
        relative.

    Returns
    -------
    x, v : (T, 3) float
        Centre of mass and its velocity, world axes.
    q : (T, 4) float
        Unit orientations (x, y, z, w), body to world.
    omega_body : (T, 3) float
        Angular velocity in body axes.
    """
    s0 = np.concatenate([np.asarray(part, dtype=float) for part in start])
    times = np.asarray(times, dtype=float)
    solution = solve_ivp(rigid_body_slope(mass, inertia, wrench), (0.0, times[-1]), s0,
                         method='DOP853', t_eval=times, rtol=rtol, atol=atol)
    if not solution.success:
        raise RuntimeError(f'reference solve failed: {solution.message}')
    s = solution.y.T
    q = s[:, 6:10] / np.linalg.norm(s[:, 6:10], axis=1, keepdims=True)
    return s[:, :3], s[:, 3:6], q, s[:, 10:]


def world_from_body(q):
    """Return the rotation matrix (3, 3) of a quaternion (x, y, z, w), body to world."""
    return Rotation.from_quat(q).as_matrix()


# Wrenches written here from the physics alone, so that the tests judge the core's effects
# and inputs with forces of their own. Each is ``wrench(time, x, v, q, omega_body) ->
# (force, torque_body)`` as :func:`rigid_body_slope` takes it; body points are relative to
# the centre of mass.
def spring_at(stiffness, point, anchor, damping=0.0):
    """Return the wrench of a zero-length spring from body ``point`` to the world ``anchor``.

    ``-k d - c d'``, ``d`` the end's offset from the anchor (world, m) and ``d'`` its
    velocity ``v + R (omega_b x point)``; ``stiffness`` N/m, ``damping`` N s/m.
    """
    point, anchor = np.asarray(point, dtype=float), np.asarray(anchor, dtype=float)

    def wrench(time, x, v, q, omega_body):
        turn = world_from_body(q)
        force = (-stiffness * (x + turn @ point - anchor)
                 - damping * (v + turn @ np.cross(omega_body, point)))
        return force, np.cross(point, turn.T @ force)
    return wrench


def uniform_field(mass, acceleration):
    """Return the wrench of a uniform field (gravity): ``mass acceleration``, no torque."""
    force = mass * np.asarray(acceleration, dtype=float)

    def wrench(time, x, v, q, omega_body):
        return force, np.zeros(3)
    return wrench


def world_force_at(force, point):
    """Return the wrench of a constant world-axes ``force`` (N) acting at body ``point`` (m)."""
    force, point = np.asarray(force, dtype=float), np.asarray(point, dtype=float)

    def wrench(time, x, v, q, omega_body):
        return force, np.cross(point, world_from_body(q).T @ force)
    return wrench


def body_torque(torque):
    """Return the wrench of a torque held in body axes (N m), no force."""
    torque = np.asarray(torque, dtype=float)

    def wrench(time, x, v, q, omega_body):
        return np.zeros(3), torque
    return wrench


def summed(*wrenches):
    """Return the wrench that is the sum of ``wrenches``."""
    def wrench(time, x, v, q, omega_body):
        parts = [w(time, x, v, q, omega_body) for w in wrenches]
        return sum(f for f, _ in parts), sum(t for _, t in parts)
    return wrench


# The simulator's packed state of one body with its centre of mass at its frame's origin:
# ``[x, q, P, L]`` (13,), P = M v and L = R I omega_b in world axes (docs/conventions.md).
def packed(mass, inertia, x, v, q, omega_body):
    """Return the packed state (13,) of ``x``, ``v``, ``q``, ``omega_body`` (oracle order)."""
    spin = world_from_body(q) @ np.asarray(inertia, dtype=float) @ omega_body
    return np.concatenate((x, q, mass * np.asarray(v), spin))


def packed_step(mass, inertia, y, dt, wrench=no_wrench, start=0.0):
    """Return the packed state (13,) ``dt`` after ``y`` (13,), at time ``start`` (s), by DOP853.

    At rtol 1e-13 and an absolute tolerance 1e-14 of each component's scale
    (:func:`scales`), far below the local errors the tests compare.
    """
    inertia = np.asarray(inertia, dtype=float)
    q = y[3:7] / np.linalg.norm(y[3:7])
    omega_body = np.linalg.solve(inertia, world_from_body(q).T @ y[10:13])
    length, momentum, angular = scales(mass, inertia, y, dt)
    scale = np.repeat([length, momentum / mass, 1.0, angular / np.diag(inertia).max()],
                      [3, 3, 4, 3])

    def shifted(time, x, v, q, omega_body):
        return wrench(start + time, x, v, q, omega_body)
    x, v, q, omega = reference_motion(mass, inertia, (y[:3], y[7:10] / mass, q, omega_body),
                                      [dt], shifted, 1e-13, 1e-14 * scale)
    return packed(mass, inertia, x[-1], v[-1], q[-1], omega[-1])


def scales(mass, inertia, y, dt):
    """Return a body's sizes: radius of gyration (m), momentum and angular momentum scales.

    The units local errors are measured in: ``sqrt(trace I / M)``, ``max(|P|, M r / dt)``
    and ``max(|L|, trace I / dt)`` of the packed state ``y`` (13,) for a step ``dt``.
    """
    trace = float(np.trace(inertia))
    length = np.sqrt(trace / mass)
    return (length, max(np.linalg.norm(y[7:10]), mass * length / dt),
            max(np.linalg.norm(y[10:13]), trace / dt))


def scaled_error(mass, inertia, reference, y, dt):
    """Return the largest component of ``y - reference`` (packed, (13,)) over its scale.

    Scales are the reference's (:func:`scales`); a quaternion counts with the reference's
    sign (q and -q are one rotation), its components unscaled.
    """
    length, momentum, angular = scales(mass, inertia, reference, dt)
    sign = 1.0 if y[3:7] @ reference[3:7] >= 0.0 else -1.0
    return max(np.abs(y[:3] - reference[:3]).max() / length,
               np.abs(sign * y[3:7] - reference[3:7]).max(),
               np.abs(y[7:10] - reference[7:10]).max() / momentum,
               np.abs(y[10:13] - reference[10:13]).max() / angular)
