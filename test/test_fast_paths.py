# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The short cuts of the step give the physics of the general path.

Bodies that share no effect are independent, so the exact free flow of a body must not depend
on which other bodies share its call (all elliptic: the unmasked path; mixed with a still and a
spherical body: the masked path). The step guard reuses the spin bound of the state it checked
at the end of the last step; a wrench held since then must still be seen. When no effect
couples bodies, the Runge-Kutta methods take one body at a time through all stages; that
changes the order of the loops, not one operation on a body.
"""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigid_sim.core.effects.base import acts_per_body
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.dispatch import CompiledCall
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.integrators import REGISTRY, make_integrator, runge_kutta, splitting
from rigid_sim.core.integrators.free_rotation import torque_free_flow
from rigid_sim.core.kinematics import largest_spin
from rigid_sim.core.state import (ANGULAR_MOMENTUM as L_COLUMNS, initial_state,
                                  LINEAR_MOMENTUM, RigidBodies)
from rigid_sim.core.world import World

AGREEMENT = 1e-13      # relative: round-off of one flow call, whatever the path
GENERATOR = np.random.default_rng(11)
COUNT = 6
MOMENTS = np.sort(GENERATOR.uniform(0.5, 3.0, (COUNT, 3)), axis=1)[:, ::-1].copy()
ANGULAR_MOMENTUM = GENERATOR.normal(scale=2.0, size=(COUNT, 3))
ORIENTATION = Rotation.random(COUNT, random_state=11).as_quat()
DT = 0.37   # s: several radians turned, so any difference in the paths would show


def test_free_flow_of_a_body_does_not_depend_on_its_companions():
    """Each asymmetric body flows to the same state, whatever its companions.

    Alone (unmasked path), with all the others (unmasked) and beside a still and a spherical
    body (masked path), the states agree to round-off; the still body stays still and the
    sphere keeps its angular momentum.
    """
    together = torque_free_flow(MOMENTS, ANGULAR_MOMENTUM, ORIENTATION, DT)
    mixed_moments = np.vstack((MOMENTS, [[1.0, 1.0, 1.0], [1.0, 2.0, 3.0]]))
    mixed_l = np.vstack((ANGULAR_MOMENTUM, [[0.3, -0.2, 0.5], [0.0, 0.0, 0.0]]))
    mixed_q = np.vstack((ORIENTATION, ORIENTATION[:2]))
    mixed = torque_free_flow(mixed_moments, mixed_l, mixed_q, DT)
    for body in range(COUNT):
        alone = torque_free_flow(MOMENTS[body:body + 1], ANGULAR_MOMENTUM[body:body + 1],
                                 ORIENTATION[body:body + 1], DT)
        for result in (together, mixed):
            for got, expected in zip(result, alone):
                scale = np.abs(expected[0]).max()
                assert np.abs(got[body] - expected[0]).max() <= AGREEMENT * scale
    np.testing.assert_array_equal(mixed[0][-1], 0.0)
    np.testing.assert_allclose(mixed[1][-1], ORIENTATION[1], rtol=AGREEMENT)
    np.testing.assert_allclose(mixed[0][-2], mixed_l[-2], rtol=AGREEMENT)


def test_guard_sees_a_wrench_held_between_steps():
    """A torque-free body moves exactly at any step, so a fast spin takes one substep.

    Once a torque is held on it, |omega| dt above the exact_split bound splits the step.
    """
    bodies = RigidBodies(('spinner',), np.ones(1), np.diag([1.0, 2.0, 3.0])[None],
                         np.zeros((1, 3)))
    y = initial_state(bodies, np.zeros((1, 3)), [[0.0, 0.0, 0.0, 1.0]], np.zeros((1, 3)),
                      [[0.0, 0.0, 20.0]])   # |omega| dt = 0.2, four times the bound
    wrenches = AppliedWrenches(bodies)
    world = World(bodies, y, [], 'exact_split', inputs=wrenches)
    dt = 0.01
    world.step(dt)
    assert world.diagnostics.substeps == 1
    wrenches.hold(0, 'push', 'body', (0.0, 0.0, 0.0), (0.0, 0.0, 0.1))
    world.step(dt)
    assert world.diagnostics.substeps > 1
    wrenches.release()
    world.step(dt)
    assert world.diagnostics.substeps == 1


def test_guard_plans_afresh_for_an_integrator_swapped_between_steps():
    """A torqued body spinning at |omega| dt = 0.2: four times exact_split's bound, under rk4's.

    Stepped with rk4 it takes one substep; once the world's integrator is swapped for
    exact_split (as the node does when its parameter changes), the very next step plans its
    split before it starts, not only when the end-of-step check finds the bound broken.
    Error control is off: the bounds are under test.
    """
    world = _torqued_spinner('rk4')
    world.step(0.01)
    assert world.diagnostics.substeps == 1
    world.integrator = make_integrator('exact_split', world, 1e-6)
    world.step(0.01)
    assert world.diagnostics.substeps > 1
    assert 'exact_split' in world.diagnostics.reason
    assert 'reached during the step' not in world.diagnostics.reason


def test_guard_plans_afresh_for_a_longer_step():
    """A torqued body at |omega| = 20 rad/s: |omega| dt 0.02 fits exact_split's bound, 0.2 not.

    The plan the end of a step makes is for a step of the same ``dt``: a longer step after it
    is split before it starts, not only once its end finds the bound broken.
    """
    world = _torqued_spinner('exact_split')
    world.step(0.001)
    assert world.diagnostics.substeps == 1
    world.step(0.01)
    bound = REGISTRY['exact_split'].bound.rotation
    assert world.diagnostics.substeps == math.ceil(20.0 * 0.01 / bound)
    assert 'reached during the step' not in world.diagnostics.reason
    assert world.diagnostics.redone_steps == 0


def test_guard_keeps_the_spin_of_the_state_a_redone_step_ended_with():
    """A body-axes torque spins a tumbling body past exact_split's bound within one step.

    The end check finds the bound broken and redoes the step in substeps, writing over its
    first attempt. The spin the guard keeps for the next step's plan is that of the state
    the step ended with: the same as the guard measures afresh.
    """
    bodies = RigidBodies(('spinner',), np.ones(1), np.diag([1.0, 2.0, 3.0])[None],
                         np.zeros((1, 3)))
    y = initial_state(bodies, np.zeros((1, 3)), [[0.0, 0.0, 0.0, 1.0]], np.zeros((1, 3)),
                      [[5.0, 0.0, 0.0]])   # |omega| dt = 0.05: within the bound
    wrenches = AppliedWrenches(bodies)
    wrenches.hold(0, 'spin', 'body', (0.0, 0.0, 0.0), (0.0, 3000.0, 6000.0))
    world = World(bodies, y, [], 'exact_split', inputs=wrenches, error_control=False)
    world.step(0.01)
    assert world.diagnostics.redone_steps >= 1
    assert 'reached during the step' in world.diagnostics.reason
    guard, bound = world.control.guard, world.integrator.bound
    kept = guard.spin_rate(bound, world.y)
    guard.forget()
    assert kept == guard.spin_rate(bound, world.y) > 0.05 / 0.01


def test_forces_held_at_world_points_between_steps_act_from_the_next_step():
    """Every step feels the world_point forces held when it starts, and no others.

    A body at rest, I = diag(1, 2, 3), steps of h = 1/1024 s: 2 steps of nothing, 6 of F1
    at p1 and, from the 5th, 2 of F2 at p2 (its hold ends then). A world-axes force adds
    F h to P whatever the body's turning: P = 6 h F1 + 2 h F2. Its torque about the centre
    of mass is R p x F; the body turns by ~1e-5 rad in these steps, so L = 6 h p1 x F1
    + 2 h p2 x F2 to 1e-4.
    """
    bodies = RigidBodies(('body',), np.ones(1), np.diag([1.0, 2.0, 3.0])[None], np.zeros((1, 3)))
    y = initial_state(bodies, np.zeros((1, 3)), [[0.0, 0.0, 0.0, 1.0]], np.zeros((1, 3)),
                      np.zeros((1, 3)))
    world = World(bodies, y, [], 'rk4', inputs=AppliedWrenches(bodies), error_control=False)
    h = 1.0 / 1024.0
    first, second = np.array([2.0, -1.0, 0.5]), np.array([0.0, 1.5, -1.0])
    at_first, at_second = np.array([0.1, 0.2, 0.0]), np.array([0.0, -0.1, 0.3])
    holds = {2: lambda: world.inputs.hold(0, 'a', 'world_point', first, point=at_first),
             4: lambda: world.inputs.hold(0, 'b', 'world_point', second, point=at_second,
                                          expires=world.time + 2 * h),
             8: lambda: world.inputs.release(0, 'a')}
    for step in range(10):
        holds.get(step, lambda: None)()
        world.step(h)
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM], 6 * h * first + 2 * h * second,
                               rtol=1e-12)
    np.testing.assert_allclose(world.y[0, L_COLUMNS],
                               6 * h * np.cross(at_first, first)
                               + 2 * h * np.cross(at_second, second), rtol=1e-4)
    assert world.inputs.held == {}


def test_compiled_call_answers_as_the_kernel():
    """Through CompiledCall the first call and those after give what the kernel gives.

    Two bodies at rest orientation, I = diag(1, 2, 3), spinning at 2 and 5 rad/s about z
    (L = I omega): the largest spin of the first alone is 2 rad/s, of both 5 rad/s.
    """
    inertia = np.diag([1.0, 2.0, 3.0])
    y = np.zeros((2, 13))
    y[:, 6] = 1.0
    y[:, 12] = [3.0 * 2.0, 3.0 * 5.0]
    inertia_inv = np.repeat(np.linalg.inv(inertia)[None], 2, axis=0)
    first = np.array([True, False])
    call = CompiledCall(largest_spin)
    for everyone, expected in ((False, 2.0), (True, 5.0), (False, 2.0)):
        assert call(y, inertia_inv, first, first, everyone) == pytest.approx(expected, 1e-15)
        assert largest_spin(y, inertia_inv, first, first, everyone) == call(
            y, inertia_inv, first, first, everyone)


def _torqued_spinner(integrator):
    """Return a body of I = diag(1, 2, 3), unturned, spinning at 20 rad/s about z, torqued.

    It holds a body-axes torque about z; error control is off: the bounds are under test.
    """
    bodies = RigidBodies(('spinner',), np.ones(1), np.diag([1.0, 2.0, 3.0])[None],
                         np.zeros((1, 3)))
    y = initial_state(bodies, np.zeros((1, 3)), [[0.0, 0.0, 0.0, 1.0]], np.zeros((1, 3)),
                      [[0.0, 0.0, 20.0]])
    wrenches = AppliedWrenches(bodies)
    wrenches.hold(0, 'push', 'body', (0.0, 0.0, 0.0), (0.0, 0.0, 0.1))
    return World(bodies, y, [], integrator, inputs=wrenches, error_control=False)


def _per_body_scene(damped=True):
    """Six bodies under gravity (and damping), holding wrenches of every kind: a World's parts.

    Body 0 holds nothing, 1 a world-axes wrench, 2 a body-axes one, 3 a force at a body
    point, 4 two world_point forces, 5 one of each.
    """
    generator = np.random.default_rng(5)
    bodies = RigidBodies(tuple(f'b{i}' for i in range(COUNT)), np.linspace(0.5, 3.0, COUNT),
                         np.array([np.diag([1.0, 1.5, 2.0]) * (1.0 + 0.2 * i)
                                   for i in range(COUNT)]),
                         generator.normal(scale=0.1, size=(COUNT, 3)))
    y = initial_state(bodies, generator.normal(size=(COUNT, 3)), ORIENTATION,
                      generator.normal(size=(COUNT, 3)), ANGULAR_MOMENTUM)
    wrenches = AppliedWrenches(bodies)
    force, torque, point = (1.0, -2.0, 0.5), (0.3, 0.1, -0.2), (0.2, -0.1, 0.3)
    for body, key, frame in ((1, 'a', 'world'), (2, 'a', 'body'), (3, 'a', 'point'),
                             (4, 'a', 'world_point'), (4, 'b', 'world_point'),
                             (5, 'a', 'world'), (5, 'b', 'body'), (5, 'c', 'point'),
                             (5, 'd', 'world_point')):
        wrenches.hold(body, key, frame, force, torque, point=np.add(point, body * 0.1))
    effects = [Gravity(bodies, (0.1, -0.2, -9.81))]
    if damped:
        effects.append(Damping(bodies, 0.3, 0.2))
    return bodies, y, effects, wrenches


def _both_orders(name, world):
    """Return the world's integrator (a body at a time) and one that goes stage by stage."""
    one_at_a_time = world.integrator
    staged = REGISTRY[name](world, world.integrator.tolerance, per_body=False)
    return one_at_a_time, staged


def _assert_both_orders_agree(name, world, y):
    """Three substeps of 0.05 s from ``y`` in both orders: the same bits, estimates too."""
    (code, got, error, largest), (staged_code, expected, staged_error, staged_largest) = \
        _advance_both(name, world, y, 0.05, 3)
    assert code == staged_code == 0
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(error, staged_error)
    assert largest == staged_largest == error.max() > 0.0
    assert not np.array_equal(got, y)


def _advance_both(name, world, state, dt, substeps):
    """Codes, end states and error estimates of both loop orders from ``state``."""
    results = []
    for integrator in _both_orders(name, world):
        y = state.copy()
        code = integrator.advance(y, 0.0, dt, substeps, world.effect_parameters())
        results.append((code, y, integrator.error.copy(), integrator.largest_error))
    return results


@pytest.mark.parametrize('name', ['rk4', 'rk4_world', 'euler'])
def test_runge_kutta_a_body_at_a_time_equals_stage_by_stage(name):
    """Gravity, damping and held wrenches act per body: the World steps a body at a time.

    Three substeps of that give the very bits, error estimates included, that the
    stage-by-stage kernel (the one springs need) gives from the same state.
    """
    bodies, y, effects, wrenches = _per_body_scene()
    world = World(bodies, y, effects, name, auto_substep=False, inputs=wrenches)
    assert acts_per_body(world.effect_parameters())
    assert world.integrator._kernel._dispatcher in (
        runge_kutta.body_axes_runge_kutta_per_body, runge_kutta.world_axes_runge_kutta_per_body)
    _assert_both_orders_agree(name, world, y)


def test_runge_kutta_a_body_at_a_time_reports_the_first_bad_substep():
    """A body whose momentum overflows fails the step with the stage-by-stage kernel's code.

    Body 3's angular momentum of 1e154 kg m^2/s gives an angular velocity whose products
    overflow to infinity in the first substep: code 1 (non-finite in substep 1 of 4), though
    the bodies before and after it are fine.
    """
    bodies, y, effects, wrenches = _per_body_scene()
    world = World(bodies, y, effects, 'rk4', auto_substep=False, inputs=wrenches)
    state = world.y.copy()
    state[3, 10:13] = 1e154
    (code, *_), (staged_code, *_) = _advance_both('rk4', world, state, 0.1, 4)
    assert code == staged_code == 1


@pytest.mark.parametrize('damped', [False, True])
@pytest.mark.parametrize('name', ['exact_split', 'exact_split4', 'dlm', 'dlm4'])
def test_splitting_a_body_at_a_time_equals_kick_by_kick(name, damped):
    """Per-body effects: each body goes through its kicks and drifts in registers.

    Three substeps of that give the very bits, error estimates included, that the kernel that
    kicks and drifts all bodies in turn (the one springs need) gives from the same state,
    with one evaluation a kick or, damped, the Runge-Kutta kick of the method's order.
    """
    bodies, y, effects, wrenches = _per_body_scene(damped=damped)
    world = World(bodies, y, effects, name, auto_substep=False, inputs=wrenches)
    assert world.integrator._kernel._dispatcher in (
        splitting.exact_flow_splitting_per_body, splitting.dlm_splitting_per_body)
    assert world.velocity_dependent == damped
    _assert_both_orders_agree(name, world, y)


@pytest.mark.parametrize('bad, code', [
    ({3: (1.78e308, 8e307)}, 2), ({2: (0.0, np.inf)}, 1),
    ({2: (1.78e308, 6e307), 4: (0.0, np.inf)}, 1)])
def test_splitting_a_body_at_a_time_reports_the_first_bad_substep(bad, code):
    """A body that goes bad fails the step with the kick-by-kick kernel's code.

    Body 3 (2 kg) at x = 1.78e308 m moving at 4e307 m/s gains 1e306 m per substep of
    0.025 s: still finite after the first, beyond the largest double after the second
    (code 2). A body with infinite momentum is non-finite in the first (code 1). With body 2
    going bad in the second substep and body 4 in the first, the earliest substep over the
    bodies wins, not the first body's.
    """
    bodies, y, effects, wrenches = _per_body_scene(damped=False)
    world = World(bodies, y, effects, 'exact_split', auto_substep=False, inputs=wrenches)
    state = world.y.copy()
    for body, (position, momentum) in bad.items():
        state[body, 0], state[body, 7] = position, momentum
    (got, *_), (staged, *_) = _advance_both('exact_split', world, state, 0.1, 4)
    assert got == staged == code


@pytest.mark.parametrize('per_body', [True, False])
@pytest.mark.parametrize('name', ['rk4', 'rk4_world', 'euler', 'semi_implicit_euler', 'dlm4',
                                  'exact_split4'])
def test_a_step_nobody_estimates_moves_the_bodies_as_an_estimated_one(name, per_body):
    """Without error control and with estimates=False the World steps without the estimate.

    The estimate only reads the stages (Runge-Kutta) or steps again beside the kept step
    (Richardson, the Yoshida compositions), so five steps give the very bits of the
    estimated kernel, in either loop order, and the estimate reads NaN (not estimated),
    never a number that says "no error".
    """
    bodies, y, effects, wrenches = _per_body_scene()
    worlds = [World(bodies, y, effects, name, auto_substep=False, inputs=wrenches,
                    error_control=False, estimates=estimates) for estimates in (True, False)]
    if name != 'semi_implicit_euler':
        for world in worlds:
            world.integrator = REGISTRY[name](world, 1e-6, world.estimates, per_body=per_body)
    for _ in range(5):
        for world in worlds:
            assert world.step(0.05)
    estimated, bare = worlds
    np.testing.assert_array_equal(bare.y, estimated.y)
    assert math.isnan(bare.diagnostics.error_estimate) and np.isnan(bare.integrator.error).all()
    assert 0.0 < estimated.diagnostics.error_estimate < math.inf


def test_only_the_methods_with_a_bare_kernel_skip_the_estimate():
    """Estimates are skipped only where nothing may read them, and only by the six methods.

    Error control reads them: asking for both is refused. exact_split has no kernel
    without its estimate, so it reports a number either way.
    """
    bodies, y, effects, wrenches = _per_body_scene()
    with pytest.raises(ValueError, match='error control'):
        World(bodies, y, effects, 'rk4', inputs=wrenches, estimates=False)
    world = World(bodies, y, effects, 'exact_split', inputs=wrenches, error_control=False,
                  estimates=False)
    assert world.step(0.05)
    assert 0.0 < world.diagnostics.error_estimate < math.inf
