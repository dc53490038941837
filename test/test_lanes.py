# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rk4`` on many bodies steps blocks of them side by side (lanes): the bits of a body at a time.

Each lane does the arithmetic the per-body kernel does for its body, in the same order, so
whatever block a body falls in (a full one, or the part-full last one whose spare lanes
repeat its last body) and whatever range a thread steps, every bit of the state, the end
slopes and the error estimates agrees; a body that goes bad stops where it does there. The
per-body kernel is itself checked against the stage-by-stage one (test_fast_paths), and that
against closed forms (test_integrators). The two kernels in lanes, with and without the
estimate, are compiled here for one scene: they compile seconds longer than the per-body
ones (docs/performance.md).
"""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigid_sim.core import dispatch, error_estimate, kinematics
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.integrators import internal_state, REGISTRY, rk4_lanes, runge_kutta
from rigid_sim.core.lanes import LANES, LANES_MIN
from rigid_sim.core.state import initial_state, RigidBodies
from rigid_sim.core.world import World

COUNT = 2 * LANES + 3   # two full blocks and part of a third


def _scene(count=COUNT):
    """Bodies under gravity and damping, holding wrenches of every kind in turn.

    Body ``i`` holds, by ``i % 5``: nothing, a world-axes wrench, a body-axes one, a force
    at a body point, a force at a world point; so neighbouring lanes see different effects.
    """
    generator = np.random.default_rng(7)
    bodies = RigidBodies(tuple(f'b{i}' for i in range(count)),
                         generator.uniform(0.5, 3.0, count),
                         np.array([np.diag(generator.uniform(1.0, 1.8, 3)) for _ in range(count)]),
                         generator.normal(scale=0.1, size=(count, 3)))
    y = initial_state(bodies, generator.normal(size=(count, 3)),
                      Rotation.random(count, random_state=7).as_quat(),
                      generator.normal(size=(count, 3)),
                      generator.normal(scale=2.0, size=(count, 3)))
    wrenches = AppliedWrenches(bodies)
    frames = (None, 'world', 'body', 'point', 'world_point')
    for body in range(count):
        if frames[body % 5] is not None:
            wrenches.hold(body, 'push', frames[body % 5], (1.0, -2.0, 0.5), (0.3, 0.1, -0.2),
                          point=(0.2, -0.1, 0.3 + 0.01 * body))
    effects = [Gravity(bodies, (0.1, -0.2, -9.81)), Damping(bodies, 0.3, 0.2)]
    return World(bodies, y, effects, 'rk4', auto_substep=False, inputs=wrenches)


def _advance(integrator, world, state, dt, substeps):
    """Code, end state, end slopes, error estimates and their largest from ``state``."""
    y = state.copy()
    code = integrator.advance(y, 0.0, dt, substeps, world.effect_parameters())
    return (code, y, integrator._end_slopes.copy(), integrator.error.copy(),
            integrator.largest_error)


def _in_lanes_and_a_body_at_a_time(world):
    """Return the world's ``rk4`` in lanes and a body at a time (both for all its bodies)."""
    lanes = REGISTRY['rk4'](world, 1e-6, in_lanes=True)
    assert lanes._kernel._dispatcher is rk4_lanes.runge_kutta_in_lanes
    return lanes, REGISTRY['rk4'](world, 1e-6, in_lanes=False)


def test_rk4_in_lanes_equals_a_body_at_a_time_in_every_block():
    """Three substeps from the same state give the same bits in lanes as a body at a time.

    The states, the slopes the next step starts from and the estimates (rates included),
    in the full blocks and in the part-full one; then a second step, continuing from the
    stored slopes, agrees as well.
    """
    world = _scene()
    lanes, one_at_a_time = _in_lanes_and_a_body_at_a_time(world)
    got = _advance(lanes, world, world.y, 0.05, 3)
    expected = _advance(one_at_a_time, world, world.y, 0.05, 3)
    assert got[0] == expected[0] == 0
    for part, other in zip(got[1:4], expected[1:4]):
        np.testing.assert_array_equal(part, other)
    assert got[4] == expected[4] == got[3].max() > 0.0
    assert not np.array_equal(got[1], world.y)
    continued = [integrator.advance(state, 0.15, 0.05, 2, world.effect_parameters(),
                                    continuing=True)
                 for integrator, state in ((lanes, got[1]), (one_at_a_time, expected[1]))]
    assert continued == [0, 0]
    np.testing.assert_array_equal(got[1], expected[1])
    np.testing.assert_array_equal(lanes.error, one_at_a_time.error)


def test_rk4_in_lanes_without_estimates_equals_a_body_at_a_time():
    """A World that reads no estimate steps in lanes without one: the same bits.

    Its kernel shares the lanes' parts with the estimating one and leaves the estimates
    alone (NaN as the largest, as a body at a time).
    """
    world = _scene()
    lanes = REGISTRY['rk4'](world, 1e-6, estimates=False, in_lanes=True)
    assert lanes._kernel._dispatcher is rk4_lanes.runge_kutta_in_lanes_unestimated
    one_at_a_time = REGISTRY['rk4'](world, 1e-6, estimates=False, in_lanes=False)
    got = _advance(lanes, world, world.y, 0.05, 3)
    expected = _advance(one_at_a_time, world, world.y, 0.05, 3)
    assert got[0] == expected[0] == 0
    np.testing.assert_array_equal(got[1], expected[1])
    np.testing.assert_array_equal(got[2], expected[2])
    assert math.isnan(got[4]) and math.isnan(expected[4])
    assert not np.array_equal(got[1], world.y)


def test_rk4_in_lanes_reports_the_earliest_bad_substep_over_the_blocks():
    """A body that goes bad stops there; the earliest substep over all blocks is reported.

    Body 3 (first block) at x = 1.78e308 m moving at 4e307 m/s gains 1e306 m per substep of
    0.025 s: finite after the first, beyond the largest double after the second (code 2).
    Body 12 (second block) with an angular momentum of 1e154 kg m^2/s overflows in the first
    (code 1), which wins though its body comes later, as a body at a time. The bodies that
    did not go bad, in both blocks and the part-full third, end where they do in a step
    without the bad ones, with their estimates; the bad ones report an infinite one.
    """
    world = _scene()
    lanes, one_at_a_time = _in_lanes_and_a_body_at_a_time(world)
    state = world.y.copy()
    state[3, 0], state[3, 7] = 1.78e308, 4e307 * world.bodies.mass[3]
    state[12, 10:13] = 1e154
    code, got, _, error, largest = _advance(lanes, world, state, 0.1, 4)
    assert code == _advance(one_at_a_time, world, state, 0.1, 4)[0] == 1
    assert np.isinf(error[[3, 12]]).all() and largest == math.inf
    assert np.isinf(got[3, 0])
    _, clean, _, clean_error, _ = _advance(lanes, world, world.y, 0.1, 4)
    good = np.setdiff1d(np.arange(COUNT), [3, 12])
    np.testing.assert_array_equal(got[good], clean[good])
    np.testing.assert_array_equal(error[good], clean_error[good])


def test_rk4_in_lanes_on_threads_gives_the_bits_of_one_call(monkeypatch):
    """Ranges of bodies on three threads split the blocks elsewhere: the same bits.

    The threads' ranges, (0, 6), (6, 12) and (12, 19), start and end inside blocks of 8.
    """
    world = _scene()
    lanes, _ = _in_lanes_and_a_body_at_a_time(world)
    monkeypatch.setattr(dispatch, 'THREADED_BODIES', COUNT)
    monkeypatch.setattr(dispatch.config, 'NUMBA_NUM_THREADS', 3)
    shared = REGISTRY['rk4'](world, 1e-6, in_lanes=True)
    assert isinstance(shared._kernel, dispatch.BodyThreads)
    got = _advance(shared, world, world.y, 0.05, 3)
    expected = _advance(lanes, world, world.y, 0.05, 3)
    assert got[0] == expected[0] == 0
    for part, other in zip(got[1:], expected[1:]):
        np.testing.assert_array_equal(part, other)


def test_only_rk4_on_many_bodies_steps_in_lanes():
    """From LANES_MIN bodies ``rk4`` steps in lanes; fewer, and the other methods, do not.

    Asking for lanes where they do not apply (world-axes momenta, effects that couple
    bodies) is refused with the reason. Nothing is compiled here.
    """
    def kernel_of(name, count, **options):
        world = _scene(count)
        return REGISTRY[name](world, 1e-6, **options)._kernel._dispatcher

    assert kernel_of('rk4', LANES_MIN) is rk4_lanes.runge_kutta_in_lanes
    assert kernel_of('rk4', LANES_MIN, estimates=False) is \
        rk4_lanes.runge_kutta_in_lanes_unestimated
    assert kernel_of('rk4', LANES_MIN - 1) is runge_kutta.body_axes_runge_kutta_per_body
    assert kernel_of('rk4_world', LANES_MIN) is runge_kutta.world_axes_runge_kutta_per_body
    assert kernel_of('euler', LANES_MIN) is runge_kutta.world_axes_runge_kutta_per_body
    with pytest.raises(ValueError, match='rk4_world cannot step these bodies in lanes'):
        kernel_of('rk4_world', LANES_MIN, in_lanes=True)
    with pytest.raises(ValueError, match='effects that each act on one body'):
        kernel_of('rk4', LANES_MIN, per_body=False, in_lanes=True)


def test_only_the_lanes_inline_the_helpers_they_call():
    """The helpers stay calls for every other kernel; the lanes inline copies of the same code.

    numba's inlining is what made every kernel compile about 3x longer when these helpers
    were inlined everywhere (docs/performance.md, "Bodies in lanes"); the copies run the
    very code of the helpers, so the arithmetic, and the bits, are theirs.
    """
    copies = {rk4_lanes._kin.matrix: kinematics.matrix,
              rk4_lanes._kin.multiply: kinematics.multiply,
              rk4_lanes._kin.normalize: kinematics.normalize,
              rk4_lanes._derivative: internal_state.derivative,
              rk4_lanes._scaled_size: error_estimate.scaled_size,
              rk4_lanes._turning_part: error_estimate.turning_part}
    for copy, original in copies.items():
        assert original.targetoptions.get('inline', 'never') == 'never'
        assert copy.targetoptions['inline'] == 'always'
        assert copy.py_func.__code__ is original.py_func.__code__
    assert rk4_lanes._derivative.py_func.__globals__['kin'] is rk4_lanes._kin
    assert rk4_lanes._kin.rotate is kinematics.rotate   # left to LLVM, which inlines it
    assert runge_kutta._squared_ratio.targetoptions.get('inline', 'never') == 'never'
