# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Motion of rigid bodies against closed forms and an independent DOP853 reference."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import physics_cases as cases
from physics_cases import TILT
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import SpringSpec, Springs
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, ORIENTATION, POSITION

GRAVITY = np.array([0.4, -0.3, -9.81])   # m/s^2, tilted so every axis is exercised
ROUNDING = 1e-11                         # relative error left by float64 sums over ~1e3 steps
ASYMMETRIC_INERTIA = TILT.as_matrix() @ np.diag([0.03, 0.05, 0.07]) @ TILT.as_matrix().T


def with_effects(bodies, effects, integrator, tolerance=1e-6, velocity=(0.5, 0.0, 1.0),
                 inputs=None):
    return cases.make_world(bodies, (0.2, -0.1, 1.0), TILT.as_quat(), velocity,
                            (3.0, -2.0, 4.0), effects, integrator, tolerance, inputs=inputs)


@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_projectile_under_gravity(name):
    """Uniform gravity.

    P = P0 + M g t exactly for every method; x = x0 + v0 t + g t^2/2 exactly for methods of order
    >= 2, within the O(dt) bound |g| t dt / 2 for order 1.
    """
    bodies = cases.make_bodies(1.5, ASYMMETRIC_INERTIA, (0.1, -0.05, 0.02))
    world = with_effects(bodies, [Gravity(bodies, GRAVITY)], name)
    x0, p0 = world.y[0, POSITION].copy(), world.y[0, LINEAR_MOMENTUM].copy()
    dt, duration = 0.02, 1.0
    cases.advance(world, dt, duration)
    p_exact = p0 + 1.5 * GRAVITY * duration
    x_exact = x0 + p0 / 1.5 * duration + 0.5 * GRAVITY * duration ** 2
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM], p_exact, rtol=0, atol=ROUNDING * 20)
    error = np.linalg.norm(world.y[0, POSITION] - x_exact)
    if REGISTRY[name].order >= 2:
        assert error < ROUNDING * 10
    else:
        assert error <= 0.5 * np.linalg.norm(GRAVITY) * duration * dt * (1 + 1e-9)


@pytest.mark.parametrize('name, sign', [('euler', -1.0), ('semi_implicit_euler', 1.0)])
def test_euler_projectile_error_is_half_g_t_dt(name, sign):
    """Summing the schemes.

    Explicit Euler drifts with the old velocity and lands g t dt / 2 short of the parabola;
    semi-implicit Euler drifts with the new one, g t dt / 2 past it.
    """
    bodies = cases.make_bodies(1.5, ASYMMETRIC_INERTIA)
    world = with_effects(bodies, [Gravity(bodies, GRAVITY)], name)
    x0, v0 = world.y[0, POSITION].copy(), world.y[0, LINEAR_MOMENTUM] / 1.5
    dt, duration = 0.01, 1.0
    cases.advance(world, dt, duration)
    parabola = x0 + v0 * duration + 0.5 * GRAVITY * duration ** 2
    np.testing.assert_allclose(world.y[0, POSITION] - parabola,
                               sign * 0.5 * GRAVITY * duration * dt, rtol=1e-8, atol=1e-12)


OFFSET_FORCE = np.array([0.6, -0.3, 0.9])   # N, world axes, fixed direction
FORCE_POINT = np.array([0.3, 0.1, -0.2])     # m, body frame


def pushed_at_point(integrator, tolerance=1e-6):
    """Return the spinning body with OFFSET_FORCE held at FORCE_POINT ('world_point' frame)."""
    bodies = cases.make_bodies(1.5, ASYMMETRIC_INERTIA, (0.1, -0.05, 0.02))
    wrenches = AppliedWrenches(bodies)
    wrenches.hold(0, 'thruster', 'world_point', OFFSET_FORCE, point=FORCE_POINT)
    return with_effects(bodies, [], integrator, tolerance, inputs=wrenches)


def point_force_invariant(world):
    """H = M v^2 / 2 + omega.L / 2 - F.(x + R r), conserved: F does work F.(v + omega x R r)."""
    snapshot = world.snapshot()
    point = snapshot.point_world(np.array([0]), FORCE_POINT[None])[0]
    return float(snapshot.kinetic_energy()[0] - OFFSET_FORCE @ point)


@pytest.mark.parametrize('name', [n for n, c in REGISTRY.items() if c.order >= 2])
def test_offset_force_moves_centre_of_mass_on_parabola(name):
    """A fixed world force at any point moves the centre of mass on the free parabola.

    Whatever rotation its torque causes, x = x0 + v0 t + F t^2 / 2M.
    """
    world = pushed_at_point(name)
    x0, v0 = world.y[0, POSITION].copy(), world.y[0, LINEAR_MOMENTUM] / 1.5
    angular_momentum0 = world.y[0, ANGULAR_MOMENTUM].copy()
    duration = 1.0
    cases.advance(world, 0.01, duration)
    expected = x0 + v0 * duration + OFFSET_FORCE * duration ** 2 / 3.0
    np.testing.assert_allclose(world.y[0, POSITION], expected, rtol=0, atol=ROUNDING * 10)
    # The torque really changed the spin (by ~|r| |F| t): this is not a free flight.
    assert np.linalg.norm(world.y[0, ANGULAR_MOMENTUM] - angular_momentum0) > 0.04


@pytest.mark.parametrize('name, dt, tolerance, allowed', [
    ('rk4', 4e-3, 1e-6, 1e-9), ('rk4', 2e-3, 1e-6, 1e-9 / 2 ** 4),
    ('dopri5', 0.05, 1e-8, 2e-7), ('dopri5', 0.05, 1e-10, 2e-9)])
def test_offset_force_conserves_its_hamiltonian(name, dt, tolerance, allowed):
    """A constant world force at a body point conserves its Hamiltonian H.

    dH/dt = F.v + omega.(Rr x F) - F.(v + omega x Rr) = 0 for a constant world force at body
    point r; the numerical drift shrinks as dt^4 for rk4 and with the tolerance for dopri5.
    """
    world = pushed_at_point(name, tolerance)
    start = point_force_invariant(world)
    energy_scale = float(world.snapshot().kinetic_energy()[0])
    cases.advance(world, dt, 1.0)
    assert abs(point_force_invariant(world) - start) < allowed * energy_scale


def damped_oscillation(d0, v0, omega0, zeta, t):
    """Return the closed form of d'' + 2 zeta omega0 d' + omega0^2 d = 0 per axis.

    Parameters
    ----------
    d0, v0 : (3,) float
        Initial displacement, m, and velocity, m/s.
    omega0 : float
        Undamped angular frequency, rad/s.
    zeta : float
        Damping ratio.
    t : (T,) float
        Times, s.

    Returns
    -------
    displacement, velocity : (T, 3) float each
        m and m/s.
    """
    t = t[:, None]
    decay = zeta * omega0
    if zeta < 1.0:
        omega_d = omega0 * np.sqrt(1.0 - zeta ** 2)
        a, b = d0, (v0 + decay * d0) / omega_d
        cos, sin, envelope = np.cos(omega_d * t), np.sin(omega_d * t), np.exp(-decay * t)
        return (envelope * (a * cos + b * sin),
                envelope * ((b * omega_d - decay * a) * cos - (a * omega_d + decay * b) * sin))
    if zeta > 1.0:
        spread = omega0 * np.sqrt(zeta ** 2 - 1.0)
        slow, fast = -decay + spread, -decay - spread
        a = (v0 - fast * d0) / (slow - fast)
        b = d0 - a
        return (a * np.exp(slow * t) + b * np.exp(fast * t),
                slow * a * np.exp(slow * t) + fast * b * np.exp(fast * t))
    b = v0 + omega0 * d0
    return (d0 + b * t) * np.exp(-omega0 * t), (b - omega0 * (d0 + b * t)) * np.exp(-omega0 * t)


@pytest.mark.parametrize('zeta', [0.2, 1.0, 2.5], ids=['under', 'critical', 'over'])
@pytest.mark.parametrize('name', ['rk4', 'dopri5'])
def test_spring_damper_at_centre_of_mass(name, zeta):
    """A zero-rest-length spring-damper at the centre of mass makes a damped oscillator.

    With force -k d - c d', each axis follows m d'' + c d' + k d = 0, whatever the body's spin.
    """
    mass, stiffness, anchor = 2.0, 18.0, np.array([1.0, 2.0, 3.0])
    omega0 = np.sqrt(stiffness / mass)
    com = np.array([0.1, -0.05, 0.02])
    bodies = cases.make_bodies(mass, ASYMMETRIC_INERTIA, com)
    spring = SpringSpec(body=0, point=com, stiffness=stiffness,
                        damping=2.0 * zeta * omega0 * mass, anchor=anchor)
    world = with_effects(bodies, [Springs(bodies, [spring])], name,
                         tolerance=cases.ADAPTIVE_TOLERANCE)
    step = cases.step_for(name, 1e-2)
    allowed = cases.allowed_error(name, omega0, step)
    d0 = world.y[0, POSITION] - anchor
    v0 = world.y[0, LINEAR_MOMENTUM] / mass
    times = np.linspace(0.5, 2.0, 4)
    displacement, velocity = damped_oscillation(d0, v0, omega0, zeta, times)
    for index in range(times.size):
        cases.advance(world, step, times[index] - world.time)
        np.testing.assert_allclose(world.y[0, POSITION] - anchor, displacement[index],
                                   rtol=0, atol=allowed * np.linalg.norm(d0))
        np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM] / mass, velocity[index],
                                   rtol=0, atol=allowed * omega0 * np.linalg.norm(d0))


def test_body_frame_pose_of_offset_centre_of_mass():
    """A body frame offset from the centre of mass by c reports its own origin and velocity.

    The origin is x - R c and its velocity v - omega x R c; under a steady spin about a
    principal axis R = exp(omega t) R0.
    """
    com = np.array([0.2, -0.1, 0.05])
    bodies = cases.make_bodies(2.0, np.diag([0.15, 0.2, 0.3]), com)
    origin0, velocity0 = np.array([1.0, 2.0, 3.0]), np.array([0.1, -0.2, 0.3])
    omega = TILT.apply([0.0, 0.0, 2.0])      # about the body's third principal axis
    world = cases.make_world(bodies, origin0, TILT.as_quat(), velocity0, omega)
    duration = 1.5
    cases.advance(world, 5e-3, duration)
    turned = Rotation.from_rotvec(omega * duration) * TILT
    com_velocity = velocity0 + np.cross(omega, TILT.apply(com))
    com_position = origin0 + TILT.apply(com) + com_velocity * duration
    origin, orientation = world.snapshot().body_frame_pose()
    origin_velocity, angular_velocity = world.snapshot().body_frame_twist()
    np.testing.assert_allclose(origin[0], com_position - turned.apply(com), atol=1e-9)
    assert cases.rotation_error(orientation[0], turned.as_quat()) < 1e-9
    np.testing.assert_allclose(origin_velocity[0],
                               com_velocity - np.cross(omega, turned.apply(com)), atol=1e-9)
    np.testing.assert_allclose(angular_velocity[0], omega, atol=1e-9)


def test_initial_pose_and_twist_are_those_of_the_body_frame():
    """initial_state takes the pose and twist of the body frame.

    Read back at t = 0 they are returned unchanged, and the centre of mass sits at origin + R c
    moving at v + omega x R c.
    """
    com = np.array([0.2, -0.1, 0.05])
    bodies = cases.make_bodies(2.0, ASYMMETRIC_INERTIA, com)
    origin0, velocity0, omega0 = np.array([1.0, 2.0, 3.0]), np.array([0.1, -0.2, 0.3]), \
        np.array([1.5, -0.7, 2.2])
    world = cases.make_world(bodies, origin0, TILT.as_quat(), velocity0, omega0)
    snapshot = world.snapshot()
    np.testing.assert_allclose(snapshot.body_frame_pose()[0][0], origin0, atol=1e-14)
    np.testing.assert_allclose(snapshot.body_frame_twist()[0][0], velocity0, atol=1e-14)
    np.testing.assert_allclose(snapshot.body_frame_twist()[1][0], omega0, atol=1e-13)
    np.testing.assert_allclose(world.y[0, POSITION], origin0 + TILT.apply(com), atol=1e-14)
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM] / 2.0,
                               velocity0 + np.cross(omega0, TILT.apply(com)), atol=1e-14)


def symmetric_top(transverse, axial, omega_body0, times):
    """Closed-form torque-free motion of moments (I1, I1, I3), starting at orientation TILT.

    omega_3 stays constant and omega_perp turns about the body axis at
    Omega = (I3 - I1) omega_3 / I1; the body turns about the fixed world L at |L| / I1 while
    turning back about its axis: R(t) = exp(L t / I1) R0 exp(-Omega t e3).

    Returns
    -------
    (T, 4) orientation (x, y, z, w) and (T, 3) body-axes angular velocity, rad/s
    """
    rate = (axial - transverse) * omega_body0[2] / transverse
    spin = Rotation.from_rotvec(np.outer(rate * times, [0.0, 0.0, 1.0]))
    world_l = TILT.apply(np.array([transverse, transverse, axial]) * omega_body0)
    precession = Rotation.from_rotvec(np.outer(times, world_l / transverse))
    return (precession * TILT * spin.inv()).as_quat(), spin.apply(omega_body0)


def asymmetric_top(moments, omega_body0, times):
    """Torque-free motion of principal moments ``moments`` from TILT, by DOP853 (reference)."""
    free_body = cases.SingleBody(mass=1.0, inertia=np.diag(moments))
    _, _, orientation, omega_body = free_body.reference(np.zeros(3), np.zeros(3),
                                                        TILT.as_quat(), omega_body0, times)
    return orientation, omega_body


TOP_STEP = 1e-2  # s; (|omega| dt)^4 ~ 1e-5 for the tops below


def assert_free_rotation_follows(name, moments, omega_body0, reference):
    """Run a torque-free body and compare with ``reference(times)`` -> (q, omega_b).

    Also checks what a torque-free body conserves: world L, energy omega.L / 2, and |q| = 1.
    """
    bodies = cases.make_bodies(1.0, np.diag(moments))
    world = cases.make_world(bodies, np.zeros(3), TILT.as_quat(), np.zeros(3),
                             TILT.apply(omega_body0), integrator=name,
                             tolerance=cases.ADAPTIVE_TOLERANCE)
    allowed = cases.allowed_error(name, np.linalg.norm(omega_body0), TOP_STEP)
    world_l = TILT.apply(np.asarray(moments) * omega_body0)
    energy = 0.5 * float(np.asarray(moments) @ omega_body0 ** 2)
    times = np.array([1.0, 2.0, 3.0, 4.0])
    orientation, omega_body = reference(times)
    for index, time in enumerate(times):
        cases.advance(world, cases.step_for(name, TOP_STEP), time - world.time)
        snapshot = world.snapshot()
        assert cases.rotation_error(world.y[0, ORIENTATION], orientation[index]) < allowed
        np.testing.assert_allclose(cases.body_angular_velocity(snapshot)[0], omega_body[index],
                                   rtol=0, atol=allowed * np.linalg.norm(omega_body0))
        np.testing.assert_allclose(snapshot.y[0, ANGULAR_MOMENTUM], world_l, rtol=0,
                                   atol=allowed * np.linalg.norm(world_l))
        assert abs(snapshot.kinetic_energy()[0] - energy) < allowed * energy
        assert abs(np.linalg.norm(world.y[0, ORIENTATION]) - 1.0) < 1e-14


@pytest.mark.parametrize('name', cases.ACCURATE)
def test_torque_free_symmetric_top(name):
    """Axisymmetric top I = (0.3, 0.3, 0.5).

    omega_3 constant, omega_perp precessing in body axes at (I3 - I1) omega_3 / I1, orientation
    exp(L t / I1) R0 exp(-Omega t e3).
    """
    moments, omega_body0 = (0.3, 0.3, 0.5), np.array([1.0, -0.5, 6.0])
    assert_free_rotation_follows(name, moments, omega_body0,
                                 lambda times: symmetric_top(0.3, 0.5, omega_body0, times))


@pytest.mark.parametrize('name', cases.ACCURATE)
def test_torque_free_asymmetric_top_near_intermediate_axis(name):
    """I = diag(1, 2, 3) spun near the intermediate axis flips (Dzhanibekov).

    Its omega_b(t) and q(t) follow Euler's equations with dq/dt = q (omega_b, 0) / 2 (DOP853 at
    1e-12).
    """
    moments, omega_body0 = (1.0, 2.0, 3.0), np.array([0.1, 5.0, 0.1])
    reference = asymmetric_top(moments, omega_body0, np.array([1.0, 2.0, 3.0, 4.0]))
    assert np.min(reference[1][:, 1]) < 0.0  # the reference really flips within 4 s
    assert_free_rotation_follows(name, moments, omega_body0, lambda times: reference)
