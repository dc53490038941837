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
