# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Fuzzing the running node: garbage on every input topic and service, random parameters.

One node (started by the test kit) takes every example of a test, over ROS from a probe
node: after each, the node still ticks, its state is finite, and each input was either
applied or refused with a short reason and counted. Which wrenches must be refused is
worked out here from the contract (frames, finiteness, subnormal components, the scene's
limits), not asked of the node.
"""
import math

import numpy as np
from hypothesis import given, strategies as st
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from std_srvs.srv import SetBool, Trigger

import ros_tools
from fuzzing import fuzz
from rigid_sim.parameters import SPECS
from rigid_sim.testing.simulation import PREPARATION_TIMEOUT

MAX_FORCE, MAX_TORQUE = 100.0, 10.0
SCENE = f"""
limits: {{max_force: {MAX_FORCE}, max_torque: {MAX_TORQUE}}}
bodies:
  - {{name: box, mass: 2.0, shape: {{type: box, size: [0.4, 0.2, 0.1]}},
     points: {{thruster: [-0.2, 0.0, 0.0]}}}}
  - {{name: rod, mass: 1.0, shape: {{type: cylinder, radius: 0.05, length: 1.0}},
     pose: {{position: [0.0, -1.0, 0.0]}}}}
"""
VALID_FRAMES = {'box': ['world', '', 'box', 'box/thruster'], 'rod': ['world', '', 'rod']}
TEXT = st.text(st.characters(blacklist_categories=('Cs',), blacklist_characters='\x00'),
               max_size=30)
FRAME_IDS = st.one_of(st.sampled_from(VALID_FRAMES['box'] + ['rod/thruster', 'map', '/']),
                      TEXT, st.integers(1000, 100_000).map(lambda n: 'x' * n))
COMPONENTS = st.one_of(st.floats(allow_subnormal=True, width=64),
                       st.sampled_from([5e-324, -15 * 5e-324, 1e300, 1e-300, 0.0, 50.0]),
                       st.floats(-MAX_TORQUE, MAX_TORQUE))
VECTORS = st.lists(COMPONENTS, min_size=3, max_size=3)
WRENCHES = st.tuples(st.just('wrench'), st.sampled_from(['box', 'rod']), FRAME_IDS, VECTORS,
                     VECTORS)
ACTIONS = st.lists(st.one_of(WRENCHES, st.tuples(st.just('pause'), st.booleans()),
                             st.tuples(st.just('reset'))), min_size=1, max_size=4)


def acceptable(body, frame_id, force, torque):
    """Return whether the contract lets this wrench act.

    It must name a frame of the body, be finite, have no subnormal component and be within
    the scene's limits.
    """
    values = np.array(force + torque)
    subnormal = np.any((values != 0.0) & (np.abs(values) < np.finfo(float).tiny))
    return (frame_id in VALID_FRAMES[body] and bool(np.all(np.isfinite(values)))
            and not subnormal and math.hypot(*force) <= MAX_FORCE
            and math.hypot(*torque) <= MAX_TORQUE)


def started(rigid_sim):
    """Return the one simulation of this test and its probe, started at its first example."""
    if not hasattr(rigid_sim, 'started'):
        sim = rigid_sim(yaml=SCENE, time_step=0.125)
        rigid_sim.started = sim, ros_tools.Probe(sim, 'box', 'rod')
    return rigid_sim.started


def assert_alive_and_finite(sim, probe):
    """Check that a tick goes through and all the node holds and publishes is finite."""
    world = sim.node.world
    before = sim.time
    sim.step(1)
    assert np.all(np.isfinite(world.y)) and math.isfinite(world.energy())
    assert sim.time > before or sim.node.paused
    for body in ('box', 'rod'):
        assert all(np.all(np.isfinite(part)) for part in probe.state(body)[:4])


@fuzz(60)
@given(actions=ACTIONS)
def test_garbage_on_every_input_is_applied_or_refused_with_a_reason(rigid_sim, actions):
    sim, probe = started(rigid_sim)
    for action in actions:
        if action[0] == 'wrench':
            _, body, frame_id, force, torque = action
            key = f'refused inputs {body}'   # listed once the body has any
            refused = int(probe.diagnostics.values().get(key, 0))
            probe.push(body, frame_id, force, torque)
            sim.step(1)
            values = probe.diagnostics.values()
            now_refused = int(values.get(key, 0)) - refused
            assert now_refused == (0 if acceptable(body, frame_id, force, torque) else 1), \
                values['last refused input']
            if now_refused:
                reason = values['last refused input']
                assert reason.startswith(f'~/{body}/wrench: ') and len(reason) < 1000
        elif action[0] == 'pause':
            response = sim.call(SetBool, 'pause', SetBool.Request(data=action[1]))
            assert response.success and sim.node.paused is action[1]
        else:
            assert sim.call(Trigger, 'reset', Trigger.Request()).success
            assert sim.time == 0.0
        assert_alive_and_finite(sim, probe)


NAMES = st.sampled_from(sorted(SPECS) + ['use_sim_time', 'rat', 'x' * 300])
PARAMETER_VALUES = st.one_of(
    st.booleans(), st.integers(-2 ** 63, 2 ** 63 - 1), st.floats(width=64), TEXT,
    st.sampled_from([0.01, 5, 1000.0, 1e-300, 10_000, 'rk4', 'dopri5', 'map', 'bad frame!',
                     'default.yaml', '/dev/zero', '/tmp', '']))
PARAMETER_SETS = st.lists(st.tuples(NAMES, PARAMETER_VALUES), min_size=1, max_size=3,
                          unique_by=lambda pair: pair[0])


@fuzz(60)
@given(changes=PARAMETER_SETS)
def test_random_parameter_sets_are_taken_or_refused_with_a_reason(rigid_sim, changes):
    """Over the set_parameters service, as any client on the graph could send them."""
    sim, _ = started(rigid_sim)
    request = SetParameters.Request(parameters=[
        Parameter(name, value=value).to_parameter_msg() for name, value in changes])
    results = sim.call(SetParameters, 'set_parameters', request).results
    assert len(results) == len(changes)
    # A scene, integrator or tolerance taken is prepared beside the running one (compiling,
    # on a cold cache, for seconds) and swapped in: the settings say so once it is.
    assert sim.node.reconfiguration.wait(PREPARATION_TIMEOUT)
    for (name, value), result in zip(changes, results):
        if result.successful:
            assert name in SPECS or name == 'use_sim_time'
            if name in SPECS:
                assert getattr(sim.node.settings, name) == value
        else:
            assert result.reason and len(result.reason) < 3000
    before = sim.time
    sim.step(1)
    world = sim.node.world
    assert np.all(np.isfinite(world.y)) and (world.time > before or world.time == 0.0)
