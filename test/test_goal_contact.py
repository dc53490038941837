# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Goals through contact: a ball that must bounce once to get there (exact mode).

The oracle is the ball's flight in closed form (:func:`flight`): ballistic arcs under
gravity between impacts on the ground ``z = 0``, each found as the root of a quadratic, the
normal velocity reversed and scaled by ``e`` there (no friction, so the horizontal motion
and the spin are untouched). Its sensitivity to the initial velocity is the saltation
matrix's (:func:`saltation_jacobian`), derived in that function's docstring. Neither reads
the code's flights.
"""
import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from rigid_sim.core.goal_flight import Flight, GoalRefused, Rollout
from rigid_sim.core.goal_problem import FD_STEP
from rigid_sim.core.goals import Goal, GoalSolver
from rigid_sim.core.scene import build_world, parse_scene

pytestmark = pytest.mark.usefixtures('every_shape_kind')   # one stage compile (conftest)

G, E, RADIUS, MASS = 9.81, 0.8, 0.1, 1.0
RESTING = 0.2    # m/s, the contact's resting speed: a slower approach ends at rest
START = np.array([0.0, 0.0, 1.0])
DT = 0.01        # s, the node's tick: the goal is flown on this grid
IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


GROUND = {'normal': [0.0, 0.0, 1.0]}
CEILING = {'normal': [0.0, 0.0, -1.0], 'offset': -1.5}   # z = 1.5 m, facing down


def ball_world(mode='exact', integrator='exact_split', planes=(GROUND,)):
    """Return a world: a ball (r 0.1 m) at START over the ground, at rest; gravity, no friction."""
    scene = {'effects': {'gravity': {'acceleration': [0.0, 0.0, -G]},
                         'contact': {'mode': mode, 'planes': list(planes),
                                     'restitution': E, 'friction': 0.0,
                                     'resting_speed': RESTING}},
             'bodies': [{'name': 'ball', 'shape': {'type': 'sphere', 'radius': RADIUS},
                         'mass': MASS, 'pose': {'position': list(START)}}]}
    return build_world(parse_scene(scene), integrator=integrator)


def _impact_after(height, speed):
    """Seconds until a ball ``height`` m above touching, rising at ``speed``, touches."""
    return (speed + math.sqrt(speed * speed + 2.0 * G * height)) / G


def flight(position, velocity, duration):
    """End position (3,), velocity (3,) and impact times of the ball's flight, closed form.

    Between impacts ``z(t) = z + v_z t - g t^2 / 2``; an impact where ``z = r`` with
    ``v_z < 0`` turns ``v_z`` into ``-e v_z``, or into rest on the ground when the
    approach is slower than the resting speed.
    """
    position, velocity = np.array(position, float), np.array(velocity, float)
    left, impacts, resting = duration, [], False
    while not resting:
        until = _impact_after(position[2] - RADIUS, velocity[2])
        if until > left:
            break
        position += velocity * until + 0.5 * np.array([0.0, 0.0, -G]) * until ** 2
        position[2] = RADIUS
        approach = velocity[2] - G * until
        resting = -approach < RESTING
        velocity[2] = 0.0 if resting else -E * approach
        left -= until
        impacts.append(duration - left)
    if resting:
        return position + velocity * left, velocity, impacts
    return (position + velocity * left + 0.5 * np.array([0.0, 0.0, -G]) * left ** 2,
            velocity + np.array([0.0, 0.0, -G]) * left, impacts)


def _ballistic(duration):
    """Return the flow's Jacobian over ``duration``: d(p, v)(t) / d(p, v)(0)."""
    phi = np.eye(6)
    phi[:3, 3:] = duration * np.eye(3)
    return phi


def saltation_jacobian(position, velocity, duration):
    """d(end position, end velocity) / d(initial velocity), (6, 3), through one impact.

    The state is ``x = (p, v)``, the flow ``f = (v, a)`` with ``a = (0, 0, -g)``, the
    guard ``h(x) = n . p - r`` (``n`` the ground's normal) and the impact's reset
    ``R x = (p, v - (1 + e) n n^T v)``. The impact time ``t_c(x0)`` moves with the start:
    ``h(x(t_c)) = 0`` gives ``dt_c = -grad h . dx(t_c^-) / (grad h . f^-)``. So a
    perturbation ``dx(t_c^-)`` just before the impact leaves it as
    ``dx(t_c^+) = S dx(t_c^-)`` with the saltation matrix

        ``S = R + (f^+ - R f^-) grad h^T / (grad h . f^-)``,

    ``f^-``, ``f^+`` the flow just before and after; for the ball ``grad h = (n, 0)``,
    ``grad h . f^- = v_n^-`` (the approach, negative). Between impacts the ballistic flow's
    Jacobian ``Phi(t) = [[I, t I], [0, I]]`` carries it, so
    ``d x(T) / d x0 = Phi(T - t_c) S Phi(t_c)``, whose velocity columns are returned.
    """
    _, _, impacts = flight(position, velocity, duration)
    assert len(impacts) == 1, 'the saltation Jacobian here is of exactly one impact'
    impact = impacts[0]
    before = np.array(velocity, float) + np.array([0.0, 0.0, -G]) * impact
    normal = np.array([0.0, 0.0, 1.0])
    reset = np.eye(6)
    reset[3:, 3:] -= (1.0 + E) * np.outer(normal, normal)
    accel = np.array([0.0, 0.0, -G])
    f_before = np.concatenate((before, accel))
    f_after = np.concatenate((reset[3:, 3:] @ before, accel))
    grad = np.concatenate((normal, np.zeros(3)))
    saltation = reset + np.outer(f_after - reset @ f_before, grad) / (grad @ f_before)
    return (_ballistic(duration - impact) @ saltation @ _ballistic(impact))[:, 3:]


def test_the_saltation_jacobian_is_the_closed_form_flight_s_derivative():
    """The hand-derived saltation product matches central differences of :func:`flight`.

    Checks the oracle itself, before it judges the solver: both are closed forms, one
    differentiated by hand, the other numerically (error ~ h^2, h = 1e-5 m/s).
    """
    velocity, step = np.array([1.0, -0.5, 2.0]), 1e-5
    expected = saltation_jacobian(START, velocity, 1.3)
    numeric = np.empty((6, 3))
    for k in range(3):
        shift = step * np.eye(3)[k]
        ahead = np.concatenate(flight(START, velocity + shift, 1.3)[:2])
        behind = np.concatenate(flight(START, velocity - shift, 1.3)[:2])
        numeric[:, k] = (ahead - behind) / (2.0 * step)
    assert np.abs(numeric - expected).max() < 1e-8
    # The impact time's motion matters: the saltation term is not the reset alone.
    naive = (_ballistic(1.3 - flight(START, velocity, 1.3)[2][0]) @ np.diag(
        [1, 1, 1, 1, 1, -E]) @ _ballistic(flight(START, velocity, 1.3)[2][0]))[:, 3:]
    assert np.abs(naive - expected).max() > 0.1


@pytest.mark.parametrize('integrator', ['exact_split', 'rk4'])
def test_the_solver_s_jacobian_through_an_impact_is_the_saltation_matrix_s(integrator):
    """The goal's flights of the ball's copies, differenced as Newton differences them.

    Thrown up and sideways at (1, -0.5, 2) m/s from 0.9 m above touching, the ball strikes
    the ground at 0.678 s and is at its second arc's rise at T = 1.3 s. The copies (one at
    the velocity, one per perturbed component, flown together on the 10 ms grid) give the
    end position and velocity; their forward differences with the solver's steps are the
    Jacobian, which must be the saltation matrix's to the differences' error (the step's
    1e-7 of the 1.3 m displacement scale times the curvature, ~1e-6).
    """
    world = ball_world(integrator=integrator)
    velocity, duration = np.array([1.0, -0.5, 2.0]), 1.3
    steps = round(duration / DT)
    rollout = Rollout(world, 0, 4)
    rollout.prepare(Flight(world, steps, DT, world.inputs), world.y)
    scale = steps * DT
    step = FD_STEP * np.maximum(1.0, np.abs(velocity) * scale) / scale
    starts = np.vstack((velocity, velocity + np.diag(step)))
    rows = np.repeat(world.y[:1], 4, axis=0)
    rows[:, 7:10] = MASS * starts
    final, _ = rollout.fly(rows)
    ends = np.hstack((final[:, :3], final[:, 7:10] / MASS))
    jacobian = (ends[1:] - ends[0]).T / step
    expected = saltation_jacobian(START, velocity, steps * DT)
    assert np.abs(jacobian - expected).max() < 1e-6 * np.abs(expected).max()
    # The end itself is the closed form's (the flight, not only its derivative).
    position, speed, _ = flight(START, velocity, steps * DT)
    assert np.abs(ends[0] - np.concatenate((position, speed))).max() < 1e-9


def _vertical_solutions(height, duration, reach):
    """Every vertical start speed within ``reach`` whose flight ends at ``height``, sorted.

    With no friction the vertical flight is apart from the horizontal: scanning the closed
    form's end height over start speeds ``[-reach, reach]`` (steps of 1e-3 m/s) and
    refining each change of sign (Brent) finds them, with 0, 1 or more bounces.
    """
    def miss(vz):
        return flight(START, (0.0, 0.0, vz), duration)[0][2] - height

    grid = np.linspace(-reach, reach, int(2 * reach / 1e-3) + 1)
    values = np.array([miss(vz) for vz in grid])
    change = np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))
    return sorted((brentq(miss, grid[k], grid[k + 1], xtol=1e-14) for k in change), key=abs)


def test_a_goal_reached_after_one_bounce_is_where_the_closed_form_flight_ends():
    """Target 1 m ahead, 0.5 m aside and low (0.4 m) at T = 1 s: the ball bounces once.

    Dropped from rest the ball would strike at 0.428 s and be at 0.417 m at T; falling a
    little faster puts it at 0.4 m. The solved twist, flown by the closed form, ends within
    1e-6 m of the target after exactly one impact; the spin stays zero. It is the nearest
    solution by the solver's metric: with no friction the horizontal velocity is the same
    for all (``(x_T - x_0) / T``) and a spin only adds, so the nearest has the least
    vertical speed, and the closed form's vertical solutions within 6 m/s are four (one
    bounce at -0.083, -3.26 and +3.57 m/s; a lob of +4.305 m/s that never lands).
    """
    world = ball_world()
    target, duration = np.array([1.0, 0.5, 0.4]), 1.0
    solution = GoalSolver(world, DT).solve(Goal(0, target, IDENTITY, duration))
    position, _, impacts = flight(START, solution.linear_velocity, duration)
    assert len(impacts) == 1
    assert np.linalg.norm(position - target) < 1e-6
    assert solution.position_error < 1e-9 and solution.orientation_error < 1e-9
    assert np.abs(solution.angular_velocity).max() < 1e-9
    assert np.abs(solution.linear_velocity[:2] - (target[:2] - START[:2]) / duration).max() \
        < 1e-9
    vertical = solution.linear_velocity[2]
    solutions = _vertical_solutions(target[2], duration, 6.0)
    assert len(solutions) > 1 and abs(solutions[0] - vertical) < 1e-6   # the nearest
    assert any(not flight(START, (0.0, 0.0, vz), duration)[2] for vz in solutions)   # a lob


def test_the_world_applying_the_solution_bounces_to_the_goal():
    """Applied and stepped by the world tick by tick, the ball is at the goal at T."""
    world = ball_world()
    solver = GoalSolver(world, DT)
    target = np.array([1.0, 0.5, 0.4])
    solver.apply(solver.solve(Goal(0, target, IDENTITY, 1.0)))
    for _ in range(100):
        world.step(DT)
    assert np.linalg.norm(world.y[0, :3] - target) < 1e-9


def test_velocity_mode_refuses_a_goal_through_contact_and_solves_one_in_the_air():
    """Velocity mode strikes impacts where steps end: the end pose jumps with the unknowns.

    Its goals' flights ignore contact, and a solution whose flight meets contact is
    refused, saying mode: exact is needed. Under a ceiling at 1.5 m, the free flight to the
    target 1 m ahead and 0.4 m up at T = 1 s is a lob rising 4.3 m/s to 1.94 m, through
    the ceiling: refused. A goal whose flight stays between the planes (0.3 s to 0.9 m up
    and 0.3 m ahead) is solved as without contact, to the closed form's end.
    """
    world = ball_world(mode='velocity', planes=(GROUND, CEILING))
    solver = GoalSolver(world, DT)
    with pytest.raises(GoalRefused, match=r'mode: exact'):
        solver.solve(Goal(0, np.array([1.0, 0.5, 0.4]), IDENTITY, 1.0))
    target = np.array([0.3, 0.0, 0.9])
    solution = solver.solve(Goal(0, target, IDENTITY, 0.3))
    position, _, impacts = flight(START, solution.linear_velocity, 0.3)
    assert not impacts and np.linalg.norm(position - target) < 1e-9


def test_a_goal_blocked_by_another_body_is_refused_saying_so():
    """The goal's flight meets the planes only; the whole world's flight has the last word.

    A heavy slab (0.2 m high, spanning x 0.4-0.6 m) lies where the ball would land at
    0.42 s on its way to the goal: the goal's own flight bounces off the ground through
    the slab, the world's lands on it. Refused, saying another body is in the way, and
    the world is left as it was.
    """
    scene = {'effects': {'gravity': {'acceleration': [0.0, 0.0, -G]},
                         'contact': {'mode': 'exact', 'planes': [GROUND], 'restitution': E,
                                     'friction': 0.0, 'resting_speed': RESTING}},
             'bodies': [{'name': 'ball', 'shape': {'type': 'sphere', 'radius': RADIUS},
                         'mass': MASS, 'pose': {'position': list(START)}},
                        {'name': 'slab', 'shape': {'type': 'box', 'size': [0.2, 2.0, 0.2]},
                         'mass': 100.0, 'pose': {'position': [0.5, 0.0, 0.1]}}]}
    world = build_world(parse_scene(scene), integrator='exact_split')
    before = world.y.copy()
    with pytest.raises(GoalRefused, match='only the ground planes: is another body in the way'):
        GoalSolver(world, DT).solve(Goal(0, np.array([1.0, 0.0, 0.4]), IDENTITY, 1.0))
    assert np.array_equal(world.y, before) and world.time == 0.0


def _struck_with_friction(velocity, spin, mu):
    """Velocity and spin after an impact of the solid ball on the ground, and if it stuck.

    The normal impulse ``m (1 + e) |v_n|`` acts through the centre; at the contact point
    ``-r n`` the slip ``u = v_t + omega x (-r n)`` meets the tangential impulse ``J``,
    which changes it by ``J / m + r^2 J / I = 7 J / (2 m)`` (``I = 2 m r^2 / 5``): it
    stops the slip, ``J = -2 m u / 7``, if that is within Coulomb's ``mu`` times the normal
    impulse, else slides, ``J = -mu m (1 + e) |v_n| u / |u|``.
    """
    normal, lever = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -RADIUS])
    push = MASS * (1.0 + E) * -velocity[2]
    slip = velocity + np.cross(spin, lever)
    slip -= (slip @ normal) * normal
    stick = -2.0 * MASS * slip / 7.0
    stuck = np.linalg.norm(stick) <= mu * push
    tangential = stick if stuck else -mu * push * slip / np.linalg.norm(slip)
    inertia = 0.4 * MASS * RADIUS ** 2
    return (velocity + (push * normal + tangential) / MASS,
            spin + np.cross(lever, tangential) / inertia, stuck)


def spinning_flight(velocity, spin, duration, mu):
    """End position, orientation (x, y, z, w), and whether it stuck, of a one-bounce flight.

    From START and the identity orientation. A ball's spin is constant in free flight (its
    inertia is isotropic), so the orientation is ``exp(omega+ s) exp(omega- t_c)``.
    """
    _, _, impacts = flight(START, velocity, duration)
    assert len(impacts) == 1
    impact = impacts[0]
    gravity = np.array([0.0, 0.0, -G])
    there = START + velocity * impact + 0.5 * gravity * impact ** 2
    after, spun, stuck = _struck_with_friction(velocity + gravity * impact, spin, mu)
    left = duration - impact
    turn = Rotation.from_rotvec(spun * left) * Rotation.from_rotvec(spin * impact)
    return there + after * left + 0.5 * gravity * left ** 2, turn.as_quat(), stuck


@pytest.mark.parametrize('mu', [0.02, 0.5])
def test_a_spinning_ball_s_goal_through_a_bounce_with_friction(mu):
    """With friction the impact trades slip for spin: the goal still lands, both ways.

    The ball spins 3 rad/s about y; the goal asks it 1 m ahead, 0.5 m aside and 0.4 m up,
    turned 0.58 rad about z, at T = 1 s. Friction at the impact couples its velocity and
    spin (:func:`_struck_with_friction`), and the solved twist, flown by that closed form,
    ends within 1e-6 m and 1e-6 rad of the goal: for ``mu = 0.5`` the impact sticks, for
    0.02 it slides (sticking would take 0.032 of the normal impulse).
    """
    scene = {'effects': {'gravity': {'acceleration': [0.0, 0.0, -G]},
                         'contact': {'mode': 'exact', 'planes': [GROUND], 'restitution': E,
                                     'friction': mu, 'resting_speed': RESTING}},
             'bodies': [{'name': 'ball', 'shape': {'type': 'sphere', 'radius': RADIUS},
                         'mass': MASS, 'pose': {'position': list(START)},
                         'twist': {'angular': [0.0, 3.0, 0.0]}}]}
    world = build_world(parse_scene(scene), integrator='exact_split')
    target = np.array([1.0, 0.5, 0.4])
    turn = Rotation.from_rotvec([0.0, 0.0, 0.58])
    solution = GoalSolver(world, DT).solve(Goal(0, target, turn.as_quat(), 1.0))
    position, orientation, stuck = spinning_flight(
        solution.linear_velocity, solution.angular_velocity, 1.0, mu)
    assert stuck == (mu == 0.5)
    assert np.linalg.norm(position - target) < 1e-6
    assert (Rotation.from_quat(orientation) * turn.inv()).magnitude() < 1e-6


def test_a_copy_that_fails_leaves_the_others_impacts_alone():
    """A copy thrown at 1e300 m/s overflows; the others bounce as the closed form says.

    The root finder integrates every row at once: a failed row must not make it give up
    on the impacts of the rows beside it.
    """
    world = ball_world()
    rollout = Rollout(world, 0, 3)
    rollout.prepare(Flight(world, 130, DT, world.inputs), world.y)
    velocities = np.array([[1.0, -0.5, 2.0], [1e300, 1e300, -1e300], [0.5, 0.0, 1.0]])
    rows = np.repeat(world.y[:1], 3, axis=0)
    rows[:, 7:10] = MASS * velocities
    final, _ = rollout.fly(rows)
    assert np.isnan(final[1]).all()
    for k in (0, 2):
        position, _, impacts = flight(START, velocities[k], 1.3)
        assert impacts and np.abs(final[k, :3] - position).max() < 1e-9
