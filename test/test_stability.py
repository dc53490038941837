# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Hard cases stay numerically stable; safeguards; refusal of inputs that would poison a state.

The cases are built by :mod:`rigid_sim.bench.stability` (the benchmark runs them longer).
Every case also runs through a bare method (``auto_substep=False``) that theory says fails
it, and the test asserts that it does: the assertion on the default can fail.
"""
import math

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from physics_cases import TILT
from rigid_sim.bench import cases as accuracy_cases
from rigid_sim.bench import stability as hard
from rigid_sim.core import kinematics, safeguards, step_control
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators import DEFAULT_INTEGRATOR
from rigid_sim.core.integrators import adaptive
from rigid_sim.core.safeguards import ENERGY_RTOL, STRANG_BOUND
from rigid_sim.core.state import (ANGULAR_MOMENTUM, ORIENTATION, POSITION, RigidBodies,
                                  initial_state)
from rigid_sim.core.world import World

# The benchmark runs one body 1e6 steps. Every step has a fixed cost whatever the number of
# bodies, so the test takes the same body-steps within this suite's budget as 100 bodies
# (100 initial conditions) advanced together for 1e3 steps.
LONG_RUN = hard.long_run_case(count=hard.LONG_RUN_BODIES, duration=10.0)
CASES = [c for c in hard.CASES if c.key != 'long_run'] + [LONG_RUN]
# The bare method theory says fails each case, and how (see docs/stability.md).
NAIVE = {
    'tumbling': ('euler', 'gains'),          # |1 + i w h| > 1: explicit Euler gains energy
    'thin_rod': ('rk4', 'loses'),            # |omega| dt = 1: RK4's |R(i)| = 0.994 damps
    'fast_spin_0.5': ('euler', 'gains'),
    'fast_spin_1': ('rk4', 'loses'),
    'fast_spin_2': ('rk4', 'loses'),
    'fast_spin_3': ('rk4', 'diverges'),      # above RK4's bound 2 sqrt(2)
    'stiff_spring': ('euler', 'diverges'),   # energy x2 per step at w dt = 1
    'damped': ('euler', 'loses'),            # (1 - c h)^n decays faster than exp(-c t)
    'long_run': ('euler', 'gains'),
    'impulse': ('rk4', 'diverges'),          # after the kick |omega| dt = 2 pi > 2.83
    'far_mesh': ('rk4', 'drifts'),           # RK4 does not conserve |L| exactly
    'tiny': ('rk4', 'loses'), 'unit': ('rk4', 'loses'), 'huge': ('rk4', 'loses'),
}


@pytest.mark.parametrize('case', CASES, ids=lambda c: c.key)
def test_default_integrator_holds_every_hard_case(case):
    """The default integrator with its safeguards holds every hard case.

    Nothing is non-finite, the energy stays within 1e-3 of its exact history (constant, or
    E0 exp(-2 c t) under damping: no artificial damping), |q| = 1 to 1e-12 and, torque-free,
    |L| is constant to 1e-12.
    """
    outcome, world = hard.run(case)
    assert outcome.finite and outcome.failed == 0, outcome
    assert outcome.energy_error < ENERGY_RTOL, outcome
    assert outcome.unit_error < hard.NORM_RTOL, outcome
    if case.torque_free:
        assert outcome.momentum_error < hard.NORM_RTOL, outcome


@pytest.mark.parametrize('case', CASES, ids=lambda c: c.key)
def test_naive_method_fails_every_hard_case(case):
    """The same case through a bare method that theory says fails it does fail, as documented.

    So each assertion of the default's test can fail.
    """
    name, verdict = NAIVE[case.key]
    short = hard.HardCase(**{**case.__dict__, 'duration': min(case.duration, 10.0)})
    outcome, world = hard.run(short, name, auto_substep=False)
    assert outcome.verdict() == verdict, outcome
    assert np.isfinite(world.y).all(), 'a non-finite state was stored'


def test_impulse_turns_the_body_by_pi_in_one_step():
    """A one-step impulse turns the body by pi, and the safeguard substeps it.

    A body-axes torque tau about principal axis z, from rest, for one step dt, turns the body
    by tau dt^2 / 2 I3 = pi about z and leaves L = tau dt and energy tau pi; the safeguard sees
    the spin reached within the step and redoes it in substeps.
    """
    case = hard.CASES_BY_KEY['impulse']
    world = case.build(DEFAULT_INTEGRATOR, True)
    q0 = world.y[0, ORIENTATION].copy()
    world.step(case.dt)
    turn = (Rotation.from_quat(q0).inv() * Rotation.from_quat(world.y[0, ORIENTATION])).as_quat()
    torque = 2.0 * np.pi * 3.0 / case.dt ** 2
    assert abs(2.0 * np.arctan2(abs(turn[2]), abs(turn[3])) - np.pi) < 1e-9
    np.testing.assert_allclose(np.abs(turn[:2]), 0.0, atol=1e-12)
    np.testing.assert_allclose(world.energy(), torque * np.pi, rtol=1e-12)
    assert world.diagnostics.substeps > 1
    assert 'reached during the step' in world.diagnostics.reason


def test_stiff_spring_substeps_follow_the_energy_bound():
    """k/m = 1e6 at dt = 1e-3 is w dt = 1.

    The default splits each step into ceil(w dt / STRANG_BOUND) substeps, says so with those
    numbers, and the mass follows x0 cos(w t) closely. A step of w dt = 100 takes the cap.
    """
    case = hard.STIFF_SPRING
    world = case.build(DEFAULT_INTEGRATOR, True)
    x0 = world.y[0, POSITION].copy()
    for _ in range(50):
        world.step(case.dt)
    assert world.diagnostics.substeps == math.ceil(1000.0 * case.dt / STRANG_BOUND)
    expected = x0 * np.cos(1000.0 * world.time)
    assert np.linalg.norm(world.y[0, POSITION] - expected) < 1e-2 * x0[0]
    assert world.diagnostics.reason.startswith(
        f'accuracy: spring/damper rate dt 1 + spin |omega| dt 0 is {1.0 / STRANG_BOUND:.3g} '
        f'{DEFAULT_INTEGRATOR} bounds')
    world.step(100 * case.dt)   # w dt = 100: more substeps than a tick may take
    assert world.diagnostics.substeps == safeguards.MAX_SUBSTEPS
    assert world.diagnostics.reason.endswith(f'; capped at {safeguards.MAX_SUBSTEPS} substeps')


def test_far_mesh_inertia_is_exact_only_when_recentred():
    """A tilted box 1e4 sizes from its origin.

    mesh_exact recentres and gets the box's inertia R diag(m (b^2 + c^2) / 12 ...) R^T to 1e-11;
    integrating about the far origin loses eps (d/l)^3 ~ 1e-4.
    """
    from rigid_sim.core.inertia import mesh_exact
    offset = np.array([1.0, 0.7, -0.3]) * 1e4
    tilt = TILT.as_matrix()
    box = trimesh.creation.box((1.0, 2.0, 3.0))
    box.apply_transform(np.block([[tilt, offset[:, None]], [np.zeros((1, 3)), 1.0]]))
    exact = tilt @ (6.0 / 12.0 * np.diag([13.0, 10.0, 5.0])) @ tilt.T
    properties = mesh_exact(box, mass=6.0)
    assert np.max(np.abs(properties.inertia - exact)) < 1e-11 * 6.5
    np.testing.assert_allclose(properties.center_of_mass, offset, rtol=1e-14)
    naive = trimesh.triangles.mass_properties(box.triangles, density=1.0)['inertia']
    assert np.max(np.abs(naive - exact)) > 1e-6 * 6.5


def test_far_mesh_body_frame_orbits_its_fixed_centre_of_mass():
    """Torque-free, the far body frame's origin circles a centre of mass in uniform motion.

    The centre of mass moves in a straight line at P/M while the body frame's origin, 1e4
    sizes away, turns about it at the constant distance |c| (to 1e-12).
    """
    case = hard.CASES_BY_KEY['far_mesh']
    world = case.build(DEFAULT_INTEGRATOR, True)
    x0, lever = world.y[0, POSITION].copy(), np.linalg.norm(world.bodies.com_in_body[0])
    velocity = world.snapshot().velocity[0].copy()
    for _ in range(100):
        world.step(case.dt)
    origin, _ = world.snapshot().body_frame_pose()
    np.testing.assert_allclose(world.y[0, POSITION], x0 + velocity * world.time, rtol=1e-13)
    assert abs(np.linalg.norm(origin[0] - world.y[0, POSITION]) / lever - 1.0) < 1e-12


def nondimensional_state(world, mass, size):
    """Return x / size, q, omega (rad/s): equal for bodies that differ only in units."""
    return np.concatenate((world.y[0, POSITION] / size, world.y[0, ORIENTATION],
                           world.snapshot().angular_velocity[0]))


@pytest.mark.parametrize('integrator', [DEFAULT_INTEGRATOR, 'dopri5'])
def test_tiny_and_huge_bodies_move_like_the_unit_body(integrator):
    """Dynamical similarity.

    A 1e-6 kg mm body and a 1e6 kg 100 m body with the same rates move, in units of their size,
    exactly as the 1 kg 1 m body (to 1e-9): the step control and the adaptive error scale are
    unit-free.
    """
    scales = {'tiny': (1e-6, 1e-3), 'unit': (1.0, 1.0), 'huge': (1e6, 1e2)}
    states = {}
    for key, (mass, size) in scales.items():
        case = hard.CASES_BY_KEY[key]
        world = case.build(integrator, True)
        for _ in range(10):
            world.step(case.dt)
        states[key] = nondimensional_state(world, mass, size)
    for key in ('tiny', 'huge'):
        np.testing.assert_allclose(states[key], states['unit'], rtol=1e-9, atol=1e-9)


def test_absolute_adaptive_tolerance_would_break_similarity(monkeypatch):
    """The check above can fail.

    With an absolute error scale (1 for every component) dopri5 holds the tiny body to 1e-6 m, a
    thousandth of its size, and its motion departs from the unit body's by far more than 1e-9.
    """
    monkeypatch.setattr(adaptive, 'state_scales', lambda model, z, dt, out: np.ones_like(z))
    states = []
    for key, mass, size in (('tiny', 1e-6, 1e-3), ('unit', 1.0, 1.0)):
        world = hard.CASES_BY_KEY[key].build('dopri5', True)
        for _ in range(10):
            world.step(0.05)
        states.append(nondimensional_state(world, mass, size))
    assert np.max(np.abs(states[0] - states[1])) > 1e-6


class NonFiniteAbove(Integrator):
    """An integrator that returns NaN for any step longer than ``limit`` s.

    A stand-in for a method past its stability bound; shorter steps give the exact
    straight-line motion.
    """

    name = 'nan_above'
    bound = safeguards.UNBOUNDED   # the world's halving retry is what is under test
    estimate_order = 1

    def __init__(self, limit):
        self.limit = limit
        self.evaluations = 0

    def _advance(self, y, time, h, substeps, effects, continuing):
        for k in range(substeps):
            y[:, POSITION] += h * 1.0
            if h > self.limit:
                y *= np.nan
                return k + 1, np.inf
        return 0, 0.0


def free_world(integrator=DEFAULT_INTEGRATOR):
    return hard.world([1.0, 2.0, 3.0], [0.1, 0.2, 0.3], (), integrator)


def test_non_finite_step_is_retried_smaller():
    """A step whose result is non-finite is rejected and retried in halves.

    Here dt/4 is finite, so two rejections, then the full step lands; nothing non-finite is stored.
    """
    world = free_world()
    world.integrator = NonFiniteAbove(0.3)
    assert world.step(1.0) is True
    assert world.diagnostics.rejected_steps == 2 and world.diagnostics.failed_steps == 0
    assert np.isfinite(world.y).all() and world.time == 1.0


def test_step_that_stays_non_finite_keeps_the_last_good_state():
    """When every retry is non-finite the step is given up without raising.

    y and time stay at the last good state, step returns False and diagnostics say why.
    """
    world = free_world()
    world.integrator = NonFiniteAbove(0.0)
    before = world.y.copy()
    assert world.step(0.01) is False
    np.testing.assert_array_equal(world.y, before)
    assert world.time == 0.0
    diagnostics = world.diagnostics
    assert diagnostics.failed_steps == 1
    assert diagnostics.rejected_steps == step_control.MAX_HALVINGS + 1
    assert 'non-finite' in diagnostics.last_failure
    world.reset()
    assert world.diagnostics == step_control.StepDiagnostics()


def test_spin_about_the_intermediate_axis_of_a_turned_body_stays_a_spin():
    """A box spun at 5 rad/s about its intermediate axis, its frame turned 30 degrees.

    The world-to-body conversion leaves ~1e-17 off-axis, an equilibrium it leaves only after ~13 s
    (ln(5 / 1e-17) / lambda, lambda = 2.9 1/s). For 1 s the default integrator must turn it
    steadily, R(t) = R0 Ry(5 t), which sn and cn computed from k^2 alone cannot follow.
    """
    moments = np.array([1.0, 2.0, 3.0])
    start = Rotation.from_euler('z', 30, degrees=True)
    bodies = RigidBodies(('box',), np.ones(1), np.diag(moments)[None], np.zeros((1, 3)))
    spin = start.apply([0.0, 5.0, 0.0])
    y = initial_state(bodies, np.zeros((1, 3)), start.as_quat()[None], np.zeros((1, 3)),
                      spin[None])
    world = World(bodies, y, (), DEFAULT_INTEGRATOR)
    for _ in range(100):
        world.step(0.01)
    expected = start * Rotation.from_rotvec([0.0, 5.0, 0.0])
    turned = Rotation.from_quat(world.y[0, ORIENTATION]) * expected.inv()
    assert turned.magnitude() <= 1e-11


def test_a_step_that_loses_the_orientation_is_rejected():
    """A step that loses the orientation is rejected like a NaN and retried smaller.

    RK4 on world L over one 20 s step of a tumbling body overflows q, which then normalises to
    zeros: finite, but no rotation. Every quaternion the World keeps is a unit one.
    """
    world = accuracy_cases.CASES_BY_KEY['tumbling'].build('rk4_world')
    assert not world.control.auto_substep   # nothing but the retry stands between q and overflow
    world.step(20.0)
    np.testing.assert_allclose(np.linalg.norm(world.y[:, ORIENTATION], axis=1), 1.0,
                               rtol=1e-12)
    assert world.diagnostics.rejected_steps >= 1
    assert 'orientation lost' in world.diagnostics.last_failure


def test_unlisted_effects_cost_nothing(monkeypatch):
    """A torque-free world on the exact flow needs no bound.

    Planning a step computes no spin at all (and takes one substep even at |omega| dt = 3).
    """
    monkeypatch.setattr(kinematics, 'largest_spin', lambda *_: pytest.fail('spin computed'))
    world = free_world()
    assert world.control.guard.plan(world.integrator, world.y, 10.0) == (1, '')


@pytest.mark.parametrize('dt', [0.0, -0.01, np.nan, np.inf])
def test_world_refuses_a_bad_time_step(dt):
    """A time step must be finite and positive.

    Anything else is a ValueError naming it, and the state and time do not change.
    """
    world = free_world()
    before = world.y.copy()
    with pytest.raises(ValueError, match='time step'):
        world.step(dt)
    np.testing.assert_array_equal(world.y, before)
    assert world.time == 0.0


def test_world_refuses_a_non_finite_initial_state():
    """A state holding NaN cannot start a world."""
    bodies = free_world().bodies
    with pytest.raises(ValueError, match='finite'):
        World(bodies, np.full((1, 13), np.nan))


@pytest.mark.parametrize('force, torque, why', [
    ((np.nan, 0.0, 0.0), (0.0, 0.0, 0.0), 'non-finite'),
    ((0.0, 0.0, 0.0), (0.0, np.inf, 0.0), 'non-finite'),
    ((2e4, 0.0, 0.0), (0.0, 0.0, 0.0), 'max_force'),
    ((0.0, 0.0, 0.0), (0.0, 0.0, -2e4), 'max_torque')])
def test_wrenches_that_would_poison_the_state_are_refused(force, torque, why):
    """A non-finite or above-limit wrench is a ValueError saying which.

    The wrenches already held, and so the motion, are unchanged.
    """
    bodies = free_world().bodies
    wrenches = AppliedWrenches(bodies)
    wrenches.hold(0, 'kept', 'world', (1.0, 0.0, 0.0))
    held = wrenches.held
    with pytest.raises(ValueError, match=why):
        wrenches.hold(0, 'new', 'world', force, torque)
    assert wrenches.held == held


@pytest.mark.parametrize('mass, inertia, why', [
    (0.0, np.eye(3), 'positive'), (-1.0, np.eye(3), 'positive'),
    (np.nan, np.eye(3), 'positive'), (np.inf, np.eye(3), 'positive'),
    (1.0, np.diag([1.0, 1.0, -1.0]), 'positive definite'),
    (1.0, np.diag([1.0, 1.0, 3.0]), 'triangle'),
    (1.0, np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), 'symmetric'),
    (1.0, np.diag([1.0, np.nan, 1.0]), 'finite')])
def test_non_physical_bodies_are_refused(mass, inertia, why):
    """Masses must be finite and positive.

    An inertia must be finite, symmetric, positive definite and obey I1 + I2 >= I3 (no mass
    distribution has otherwise).
    """
    with pytest.raises(ValueError, match=why):
        RigidBodies(('b',), np.array([mass]), inertia[None], np.zeros((1, 3)))


@pytest.mark.parametrize('names, mass, inertia, com, why', [
    ((), np.ones(0), np.ones((0, 3, 3)), np.zeros((0, 3)), 'at least one body'),
    (('a', 'b'), np.ones(2), np.eye(3)[None], np.zeros((2, 3)), 'inertia_body must have'),
    (('a',), np.ones(2), np.eye(3)[None], np.zeros((1, 3)), 'mass must have shape'),
    (('a',), np.ones(1), np.eye(3)[None], np.zeros((1, 2)), 'com_in_body must have'),
    (('a',), np.ones(1), np.eye(3)[None], np.full((1, 3), np.nan), 'finite')])
def test_inconsistent_bodies_are_refused(names, mass, inertia, com, why):
    """Inconsistent bodies are refused.

    Every per-body array has one entry per name (one inertia for two bodies would be broadcast
    silently), a world has a body, and centres of mass are finite.
    """
    with pytest.raises(ValueError, match=why):
        RigidBodies(names, mass, inertia, com)


def test_damped_angular_momentum_decays_exactly():
    """Angular damping keeps L's direction and scales it by exp(-c t), whatever the tumbling.

    Up to the explicit-midpoint kick's error c^3 h^2 t / 6 (its e^-x - (1 - x + x^2/2) per
    step), tau = -c L is integrated exactly.
    """
    case = hard.CASES_BY_KEY['damped']
    world = case.build(DEFAULT_INTEGRATOR, True)
    l0 = world.y[0, ANGULAR_MOMENTUM].copy()
    for _ in range(40):
        world.step(case.dt)
    expected = l0 * np.exp(-hard.DAMPING_RATE * world.time)
    h = case.dt / world.diagnostics.substeps
    allowed = hard.DAMPING_RATE ** 3 * h ** 2 * world.time / 6.0
    np.testing.assert_allclose(world.y[0, ANGULAR_MOMENTUM], expected, rtol=allowed)


def _substep_counts(steps=3000):
    """Substeps of each step of the one-body long run (dt 0.01 s, default integrator)."""
    world = hard.long_run_case().build(DEFAULT_INTEGRATOR, True)
    counts = []
    for _ in range(steps):
        world.step(0.01)
        counts.append(world.diagnostics.substeps)
    return np.array(counts)


def test_substep_count_holds_while_the_need_hovers_at_a_bound(monkeypatch):
    """The substep count is raised once and held while the need hovers at a bound.

    A spinning body on a spring needs ~0.7 of the Strang bound for the spring and 0.2-0.4 for
    its spin, so its need crosses 1 again and again. Each change of step size moves the energy
    a symplectic method keeps; without the margin the count would follow every crossing.
    """
    counts = _substep_counts()
    assert np.count_nonzero(np.diff(counts)) <= 1 and counts[-1] == 2
    monkeypatch.setattr(safeguards, 'KEEP_MARGIN', 1.0)
    assert np.count_nonzero(np.diff(_substep_counts())) > 2
