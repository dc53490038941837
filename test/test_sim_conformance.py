# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""simulation_interfaces as the standard words it, and as a hostile client calls it, over DDS.

A ``rigid_sim_node`` process serves the module (rate 0, started paused, time_step 0.01 s);
the client lives in this process and is made with rclpy's defaults, as a user's would be.
A filter that kills the node or holds its executor is caught by the next call: the node's
process has exited, or the call is not answered within the client's timeout. Expected
values come from the definitions: POSIX character classes, the standard's result codes, one
feedback message per step, and the scene's own poses at time 0.
"""
import time

import numpy as np
import pytest
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import EntityFilters, Result, SimulationState
from simulation_interfaces.srv import ResetSimulation

from sim_client import SimProcess, stop_simulation

DT = 0.01
# No 'x' in the long name: `(.?){56}x` must fail on it, which a backtracking matcher takes
# about 2^56 tries to find out.
LONG = 'a_body_whose_long_name_makes_backtracking_blow_up'
SCENE = f"""
effects: {{gravity: {{acceleration: [0.0, 0.0, -9.81]}}}}
bodies:
  - {{name: box, shape: {{type: box, size: [0.2, 0.2, 0.2]}}, mass: 1.0}}
  - {{name: crate2, shape: {{type: box, size: [0.2, 0.2, 0.2]}}, mass: 1.0,
     pose: {{position: [1.0, 0.0, 0.0]}}}}
  - {{name: {LONG}, shape: {{type: sphere, radius: 0.1}}, mass: 1.0,
     pose: {{position: [2.0, 0.0, 0.0]}}}}
"""
OK = Result.RESULT_OK
NAMES = ['box', 'crate2', LONG]
# Bodies of the many-body scene, placed where their index says.
MANY = 3000
QUEUE = 10   # messages rclpy's action client keeps of its feedback by default
PACE = 1 / 200   # s: the README's bound, at most 200 SimulateSteps ticks a second


@pytest.fixture(scope='module')
def sim(tmp_path_factory):
    """Start the node process on SCENE and a default client, for the whole module."""
    folder = tmp_path_factory.mktemp('conformance')
    (folder / 'scene.yaml').write_text(SCENE)
    process = SimProcess(str(folder / 'scene.yaml'), f'/sc{id(folder) % 100000}', folder,
                         'rate:=0', 'start_paused:=true', f'time_step:={DT}')
    yield process
    process.close()


@pytest.fixture
def stopped(sim):
    """Stop the simulation: the scene as loaded, paused, at time 0."""
    stop_simulation(sim)
    return sim


def entities(sim, pattern):
    """Return the GetEntities answer for name filter ``pattern``."""
    return sim.call('get_entities', filters=EntityFilters(filter=pattern))


def assert_alive(sim):
    """Assert the node's process runs and answers a call."""
    assert sim.process.poll() is None, 'the node exited'
    answer = sim.call('get_simulation_state')
    assert answer.result.result == OK


def test_filter_speaks_posix_character_classes(stopped):
    sim = stopped
    assert entities(sim, '^[[:alpha:]]+[[:digit:]]$').entities == ['crate2']
    assert entities(sim, '^[[:lower:]_]+$').entities == ['box', LONG]
    assert entities(sim, '').entities == NAMES       # empty: every entity, in scene order
    assert entities(sim, 'box|crate').entities == ['box', 'crate2']


def test_perl_only_syntax_is_refused_with_a_reason(stopped):
    """Perl's digit class is no POSIX extended syntax: refused, not read as something else."""
    answer = entities(stopped, r'crate\d').result
    assert answer.result == Result.RESULT_OPERATION_FAILED
    assert 'POSIX' in answer.error_message
    assert_alive(stopped)


def test_a_huge_repetition_count_does_not_kill_the_node(stopped):
    """`a{4294967296}` overflowed Python's re; no name holds 2^32 a's, so nothing matches."""
    answer = entities(stopped, 'a{4294967296}')
    assert answer.result.result in (OK, Result.RESULT_OPERATION_FAILED)
    assert list(answer.entities) == []
    assert_alive(stopped)


def test_deep_nesting_is_refused_and_the_node_lives(stopped):
    answer = entities(stopped, '(' * 1200 + 'box' + ')' * 1200).result
    assert answer.result == Result.RESULT_OPERATION_FAILED
    assert 'limit' in answer.error_message
    assert_alive(stopped)
    states = stopped.call('get_entities_states', filters=EntityFilters(filter='(' * 1200))
    assert states.result.result == Result.RESULT_OPERATION_FAILED and not states.states
    assert_alive(stopped)


def test_nesting_within_the_length_limit_matches(stopped):
    assert entities(stopped, '(' * 400 + 'box' + ')' * 400).entities == ['box']


def test_a_backtracking_bomb_is_answered_and_control_still_answers(stopped):
    """`(.?){56}x` on a long name without x: linear work; only box has an x."""
    answer = stopped.call('get_entities_states', filters=EntityFilters(filter='(.?){56}x'))
    assert answer.result.result == OK and list(answer.entities) == ['box']
    assert entities(stopped, '(.?){56}_up$').entities == [LONG]
    assert_alive(stopped)


def test_undefined_reset_scope_bits_are_refused_and_nothing_is_reset(stopped):
    sim, scope = stopped, ResetSimulation.Request
    assert sim.call('step_simulation', steps=3).result.result == OK
    for undefined in (8, 16 | scope.SCOPE_TIME, 128):
        answer = sim.call('reset_simulation', scope=undefined).result
        assert answer.result == Result.RESULT_FEATURE_UNSUPPORTED, undefined
        assert str(undefined) in answer.error_message
    state = sim.call('get_entity_state', entity='box').state
    assert state.header.stamp.nanosec == round(3 * DT * 1e9)   # time not reset
    assert sim.call('reset_simulation', scope=scope.SCOPE_ALL).result.result == OK


def test_steps_while_playing_fail_as_the_definitions_say(stopped):
    """StepSimulation.srv and SimulateSteps.action: not paused, RESULT_OPERATION_FAILED."""
    sim, s = stopped, SimulationState
    assert sim.call('set_simulation_state', state=s(state=s.STATE_PLAYING)).result.result == OK
    refused = sim.call('step_simulation', steps=1).result
    assert refused.result == Result.RESULT_OPERATION_FAILED and 'paused' in refused.error_message
    goal = sim.action.send_goal_async(SimulateSteps.Goal(steps=2))
    sim.until(goal.done, 'goal answered')
    outcome = goal.result().get_result_async()
    sim.until(outcome.done, 'result')
    assert outcome.result().result.result.result == Result.RESULT_OPERATION_FAILED


def test_a_default_client_that_works_on_each_feedback_receives_every_step(stopped):
    """A client with rclpy's defaults: feedback queue 10, result asked for at acceptance.

    The client spends 2 ms on each message (a user's logging or control), as clients do.
    Steps are at least PACE apart, so the queue of 10 overflows only while the
    client takes nothing for ten periods: every step arrives unless the client itself
    stalled that long (a loaded machine may deschedule it), and then the steps lost are
    those that came during the stall (the wait from sending the goal to the first message
    counts: the node steps from the goal's acceptance on).
    """
    sim, steps, received = stopped, 100, []
    taken = [time.monotonic()]

    def work(message):
        taken.append(time.monotonic())
        received.append((message.feedback.completed_steps, message.feedback.remaining_steps))
        time.sleep(0.002)   # the client's own work per message, not a wait for the node
    goal = sim.action.send_goal_async(SimulateSteps.Goal(steps=steps), feedback_callback=work)
    sim.until(goal.done, 'goal accepted')
    outcome = goal.result().get_result_async()
    sim.until(outcome.done, 'result')
    assert outcome.result().result.result.result == OK
    every = [(n, steps - n) for n in range(1, steps + 1)]
    if received != every:
        lost = sorted(set(every) - set(received))
        stall = max(later - earlier for earlier, later in zip(taken, taken[1:]))
        assert stall >= QUEUE * PACE, f'{len(lost)} lost ({lost[:3]}...), the client never stalled'
    assert received == sorted(received) and received[-1] == every[-1]
    state = sim.call('get_entity_state', entity='box').state
    assert state.header.stamp.sec + state.header.stamp.nanosec * 1e-9 == pytest.approx(
        steps * DT, abs=1e-9)


@pytest.fixture(scope='module')
def many(tmp_path_factory):
    """Start a node on MANY bodies at rest, body i at (i, -2 i, 300 + i / 1000) cm."""
    folder = tmp_path_factory.mktemp('many')
    lines = ['bodies:'] + [
        f'  - {{name: g{i}, shape: {{type: sphere, radius: 0.001}}, mass: 1.0, '
        f'pose: {{position: [{i * 0.01!r}, {-i * 0.02!r}, {3.0 + i * 1e-5!r}]}}}}'
        for i in range(MANY)]
    (folder / 'many.yaml').write_text('\n'.join(lines) + '\n')
    process = SimProcess(str(folder / 'many.yaml'), f'/mb{id(folder) % 100000}', folder,
                         'rate:=0', 'start_paused:=true', f'max_answer_states:={MANY}')
    yield process
    process.close()


def test_all_states_of_many_bodies_are_each_bodys_own(many):
    """Every state is its own body's (its pose from the scene), for all and for a filter."""
    answer = many.call('get_entities_states', filters=EntityFilters())
    assert answer.result.result == OK
    assert list(answer.entities) == [f'g{i}' for i in range(MANY)]
    positions = np.array([[s.pose.position.x, s.pose.position.y, s.pose.position.z]
                          for s in answer.states])
    index = np.arange(MANY)
    np.testing.assert_allclose(positions, np.column_stack(
        [index * 0.01, -index * 0.02, 3.0 + index * 1e-5]), rtol=0, atol=1e-12)
    assert {s.header.frame_id for s in answer.states} == {'world'}
    sevens = many.call('get_entities_states', filters=EntityFilters(filter='^g[[:digit:]]*7$'))
    wanted = [i for i in range(MANY) if i % 10 == 7]
    assert list(sevens.entities) == [f'g{i}' for i in wanted]
    assert [s.pose.position.x for s in sevens.states] == pytest.approx(
        [i * 0.01 for i in wanted], abs=1e-12)
    assert_alive(many)


def test_without_re2_a_name_filter_is_refused_as_unsupported(monkeypatch):
    """A ROS install without google-re2 lists every entity and refuses to match names."""
    from types import SimpleNamespace
    from rigid_sim import entity_services
    monkeypatch.setattr(entity_services, 're2', None)
    services = SimpleNamespace()
    filters = EntityFilters(filter='box')
    refusal = entity_services.EntityServices._pattern(services, filters)
    assert refusal[0] == Result.RESULT_FEATURE_UNSUPPORTED and 'google-re2' in refusal[1]
    assert entity_services.EntityServices._pattern(services, EntityFilters()) is None
