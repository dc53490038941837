# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""simulation_interfaces over DDS: a ``rigid_sim_node`` process and a client in this one.

Every service and the action is called with the real generated types, refusals included.
One node process serves the module (rate 0, started paused, time_step 0.01 s); each test
starts by setting it STOPPED, which puts back the scene as loaded at time 0. Expected
motions are closed forms: under gravity g alone a body falls ``g t^2 / 2`` from rest.
"""
import math
from pathlib import Path
import re
import signal
import subprocess
import sys

from geometry_msgs.msg import PoseStamped, WrenchStamped
import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import EntityFilters, Result, SimulationState, SimulatorFeatures
from simulation_interfaces.srv import (
    ResetSimulation, SetEntityState, SetSimulationState, SpawnEntity)

import processes
from sim_client import EXECUTABLE, SimProcess, START_TIMEOUT, stop_simulation

ROOT = Path(__file__).resolve().parents[1]
G = 9.81
DT = 0.01
HALF_TURN_Z = [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)]   # 90 degrees about z
SCENE = f"""
effects: {{gravity: {{acceleration: [0.0, 0.0, -{G}]}}}}
bodies:
  - {{name: box, shape: {{type: box, size: [0.2, 0.2, 0.2]}}, mass: 1.0,
     pose: {{position: [0.0, 0.0, 1.0]}}}}
  - {{name: plate, shape: {{type: box, size: [1.0, 1.0, 0.1]}}, mass: 2.0,
     pose: {{position: [1.0, 0.0, 0.0], orientation: {HALF_TURN_Z}}},
     twist: {{angular: [0.0, 0.0, 1.0]}}}}
"""
BALL = '{shape: {type: sphere, radius: 0.1}, mass: 2.0, pose: {position: [9.0, 9.0, 9.0]}}'
OK = Result.RESULT_OK


@pytest.fixture(scope='module')
def sim(tmp_path_factory):
    """Start the node process on SCENE and its client, for the whole module."""
    folder = tmp_path_factory.mktemp('sim_interfaces')
    (folder / 'scene.yaml').write_text(SCENE)
    process = SimProcess(str(folder / 'scene.yaml'), f'/si{id(folder) % 100000}', folder,
                         'rate:=0', 'start_paused:=true')
    process.folder = folder   # its working directory: where it may read spawned files
    yield process
    process.close()


@pytest.fixture
def stopped(sim):
    """Stop the simulation: the scene as loaded, paused, at time 0."""
    stop_simulation(sim)
    assert simulation_state(sim) == SimulationState.STATE_STOPPED
    return sim


def state_of(sim, entity):
    """(position, orientation, velocity, angular velocity, time) of ``entity``, world."""
    answer = sim.call('get_entity_state', entity=entity)
    assert answer.result.result == OK, answer.result.error_message
    s = answer.state
    p, q, v, w = s.pose.position, s.pose.orientation, s.twist.linear, s.twist.angular
    stamp = s.header.stamp.sec + s.header.stamp.nanosec * 1e-9
    assert s.header.frame_id == 'world'
    return (np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w]), np.array([v.x, v.y, v.z]),
            np.array([w.x, w.y, w.z]), stamp)


def simulation_state(sim):
    return sim.call('get_simulation_state').state.state


def spawn(sim, name='', resource='', uri='', position=None, frame_id='', renaming=False,
          orientation=(0.0, 0.0, 0.0, 1.0)):
    pose = PoseStamped()
    pose.header.frame_id = frame_id
    if position is not None:
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = position
    q = pose.pose.orientation
    q.x, q.y, q.z, q.w = orientation
    return sim.call('spawn_entity', name=name, resource_string=resource, uri=uri,
                    allow_renaming=renaming, initial_pose=pose)


def test_features_list_what_is_served_and_nothing_else(sim):
    f = SimulatorFeatures
    served = set(sim.call('get_simulator_features').features.features)
    assert {f.SPAWNING, f.DELETING, f.SPAWNING_RESOURCE_STRING, f.ENTITY_STATE_GETTING,
            f.ENTITY_STATE_SETTING, f.SIMULATION_RESET, f.SIMULATION_STATE_PAUSE,
            f.STEP_SIMULATION_MULTIPLE, f.STEP_SIMULATION_ACTION} <= served
    assert not served & {f.NAMED_POSES, f.ENTITY_TAGS, f.ENTITY_BOUNDS, f.ENTITY_CATEGORIES,
                         f.SPAWNABLES, f.WORLD_LOADING, f.SPAWNING_ENTITIES}


def test_stopped_paused_playing_and_steps_only_while_paused(stopped):
    sim, s = stopped, SimulationState
    assert simulation_state(sim) == s.STATE_STOPPED
    assert sim.call('step_simulation', steps=10).result.result == OK
    assert simulation_state(sim) == s.STATE_PAUSED   # it has left the initial state
    position, _, velocity, _, time = state_of(sim, 'box')
    assert time == pytest.approx(10 * DT, abs=1e-12)
    assert position[2] == pytest.approx(1.0 - G * time ** 2 / 2, abs=1e-12)
    assert velocity[2] == pytest.approx(-G * time, abs=1e-12)
    again = sim.call('set_simulation_state', state=s(state=s.STATE_PAUSED)).result.result
    assert again == SetSimulationState.Response.ALREADY_IN_TARGET_STATE
    assert sim.call('set_simulation_state', state=s(state=s.STATE_PLAYING)).result.result == OK
    assert simulation_state(sim) == s.STATE_PLAYING
    refused = sim.call('step_simulation', steps=1).result
    assert refused.result == Result.RESULT_OPERATION_FAILED and 'paused' in refused.error_message
    assert sim.call('set_simulation_state', state=s(state=s.STATE_STOPPED)).result.result == OK
    assert simulation_state(sim) == s.STATE_STOPPED
    position, _, velocity, _, time = state_of(sim, 'box')
    assert (time, position.tolist(), velocity.tolist()) == (0.0, [0.0, 0.0, 1.0], [0.0] * 3)


def test_spawn_while_paused_then_step(stopped):
    """initial_pose overrides the entry's pose; the others' state and the time are kept."""
    sim = stopped
    assert sim.call('step_simulation', steps=3).result.result == OK
    box_before = state_of(sim, 'box')
    answer = spawn(sim, 'ball', BALL, position=(0.5, 0.0, 2.0))
    assert (answer.result.result, answer.entity_name) == (OK, 'ball')
    box_after = state_of(sim, 'box')
    for before, after in zip(box_before, box_after):
        np.testing.assert_array_equal(before, after)
    poses = []
    sim.node.create_subscription(PoseStamped, f'{sim.prefix}/ball/pose', poses.append, 10)
    assert sim.call('step_simulation', steps=10).result.result == OK
    position, _, velocity, _, time = state_of(sim, 'ball')
    assert time == pytest.approx(13 * DT, abs=1e-12)
    falling = 10 * DT   # the ball fell from rest since its spawn
    np.testing.assert_allclose(position, [0.5, 0.0, 2.0 - G * falling ** 2 / 2], atol=1e-12)
    np.testing.assert_allclose(velocity, [0.0, 0.0, -G * falling], atol=1e-12)

    def heard():
        """Whether a pose arrived; if not, step once more.

        Paused at rate 0 the node publishes only when it steps, to the subscribers it has
        found (it looks again every LISTENER_REFRESH of wall time); on a loaded machine the
        ten steps above can all come before it finds this one.
        """
        if not poses:
            assert sim.call('step_simulation', steps=1).result.result == OK
        return bool(poses)

    sim.until(heard, 'a pose on the spawned ball/pose topic')


def test_spawn_refusals_use_the_standard_codes(stopped):
    sim, codes = stopped, SpawnEntity.Response
    taken = spawn(sim, 'box', BALL).result
    assert taken.result == codes.NAME_NOT_UNIQUE and "'box'" in taken.error_message
    renamed = spawn(sim, 'box', BALL, renaming=True)
    assert (renamed.result.result, renamed.entity_name) == (OK, 'box_1')
    bad_turn = spawn(sim, 'ball', BALL, position=(0.0, 0.0, 1.0), orientation=(0.0,) * 4)
    assert bad_turn.result.result == codes.INVALID_POSE
    assert 'not a unit quaternion' in bad_turn.result.error_message
    negative = spawn(sim, 'ball', '{shape: {type: sphere, radius: 0.1}, mass: -1.0}').result
    assert negative.result == codes.RESOURCE_PARSE_ERROR
    assert negative.error_message.startswith('resource_string: mass:')
    not_yaml = spawn(sim, 'ball', '{shape: [').result
    assert not_yaml.result == codes.RESOURCE_PARSE_ERROR and 'YAML' in not_yaml.error_message
    mesh = '{shape: {type: mesh, file: nowhere.stl}, mass: 1.0}'
    assert spawn(sim, 'ball', mesh).result.result == codes.MISSING_ASSETS
    assert spawn(sim, '1ball', BALL).result.result == codes.NAME_INVALID
    assert spawn(sim, 'ball').result.result == codes.NO_RESOURCE
    spaced = sim.call('spawn_entity', name='ball', resource_string=BALL, entity_namespace='ns')
    assert spaced.result.result == Result.RESULT_FEATURE_UNSUPPORTED
    unknown_frame = spawn(sim, 'ball', BALL, frame_id='nowhere').result
    assert unknown_frame.result == codes.INVALID_POSE and 'nowhere' in unknown_frame.error_message
    assert sim.call('get_entities').entities == ['box', 'plate', 'box_1']


def test_unknown_entities_are_not_found(stopped):
    sim = stopped
    for service, fields in (('get_entity_state', {}), ('set_entity_state', {}),
                            ('delete_entity', {})):
        answer = sim.call(service, entity='ghost', **fields).result
        assert answer.result == Result.RESULT_NOT_FOUND and "'ghost'" in answer.error_message


def set_state(sim, entity, position, orientation, linear, angular, frame_id=''):
    request = SetEntityState.Request(entity=entity)
    state = request.state
    state.header.frame_id = frame_id
    p, q = state.pose.position, state.pose.orientation
    p.x, p.y, p.z = position
    q.x, q.y, q.z, q.w = orientation
    state.twist.linear.x, state.twist.linear.y, state.twist.linear.z = linear
    state.twist.angular.x, state.twist.angular.y, state.twist.angular.z = angular
    return sim.call('set_entity_state', entity=entity, state=state).result


def test_set_entity_state_in_the_world_and_in_another_entitys_frame(stopped):
    """Relative to the plate (at (1, 0, 0), turned 90 degrees about z, spinning at 1 rad/s).

    At rest in the plate's frame at (1, 0, 0) of it, the box is at (1, 1, 0) in the world,
    moving with the plate's spin: w x r = (0, 0, 1) x (0, 1, 0) = (-1, 0, 0) m/s.
    """
    sim = stopped
    assert set_state(sim, 'box', (0.0, 0.0, 3.0), HALF_TURN_Z, (1.0, 0.0, 0.0),
                     (0.0, 0.0, 2.0)).result == OK
    position, orientation, velocity, angular, _ = state_of(sim, 'box')
    np.testing.assert_allclose(position, [0.0, 0.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(orientation, HALF_TURN_Z, atol=1e-12)
    np.testing.assert_allclose(velocity, [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(angular, [0.0, 0.0, 2.0], atol=1e-12)
    assert set_state(sim, 'box', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), (0.0,) * 3, (0.0,) * 3,
                     frame_id='plate').result == OK
    position, orientation, velocity, angular, _ = state_of(sim, 'box')
    np.testing.assert_allclose(position, [1.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(orientation, HALF_TURN_Z, atol=1e-12)
    np.testing.assert_allclose(velocity, [-1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(angular, [0.0, 0.0, 1.0], atol=1e-12)
    bad = set_state(sim, 'box', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0), (0.0,) * 3, (0.0,) * 3)
    assert bad.result == SetEntityState.Response.INVALID_POSE
    np.testing.assert_allclose(state_of(sim, 'box')[0], [1.0, 1.0, 0.0], atol=1e-12)
    unknown = set_state(sim, 'box', (0.0,) * 3, (0.0, 0.0, 0.0, 1.0), (0.0,) * 3, (0.0,) * 3,
                        frame_id='ghost')
    assert unknown.result == Result.RESULT_NOT_FOUND


def test_set_entity_state_refuses_an_acceleration_and_changes_nothing(stopped):
    """An acceleration follows from the forces: a non-zero or non-finite one is refused.

    Accepting it would drop it silently; the body stays where it was set before.
    """
    sim = stopped
    assert set_state(sim, 'box', (0.0, 0.0, 3.0), HALF_TURN_Z, (1.0, 0.0, 0.0),
                     (0.0, 0.0, 2.0)).result == OK
    for value in (1.0, float('nan'), float('inf')):
        request = SetEntityState.Request(entity='box')
        request.state.pose.orientation.w = 1.0
        request.state.acceleration.angular.y = value
        answer = sim.call('set_entity_state', entity='box', state=request.state).result
        assert answer.result == Result.RESULT_FEATURE_UNSUPPORTED
        assert 'acceleration' in answer.error_message
        np.testing.assert_allclose(state_of(sim, 'box')[0], [0.0, 0.0, 3.0], atol=1e-12)


def test_entities_by_name_filter_and_their_states(stopped):
    sim = stopped
    assert sim.call('get_entities').entities == ['box', 'plate']
    assert sim.call('get_entities', filters=EntityFilters(filter='^pl')).entities == ['plate']
    tagged = EntityFilters()
    tagged.tags.tags = ['robot']
    assert (sim.call('get_entities', filters=tagged).result.result
            == Result.RESULT_FEATURE_UNSUPPORTED)
    both = sim.call('get_entities_states')
    assert both.entities == ['box', 'plate']
    assert [s.pose.position.x for s in both.states] == [0.0, 1.0]


def test_deleted_body_loses_its_topics_and_its_held_wrench(stopped):
    """A wrench held on 'puck' is gone with it: a new 'puck' falls freely."""
    sim = stopped
    assert spawn(sim, 'puck', BALL, position=(0.0, 2.0, 0.0)).result.result == OK
    push = sim.node.create_publisher(WrenchStamped, f'{sim.prefix}/puck/wrench', 10)
    sim.until(lambda: push.get_subscription_count() >= 1, 'puck/wrench matched')
    wrench = WrenchStamped()
    wrench.header.frame_id = 'world'
    wrench.wrench.force.z = 100.0

    def pushed_up():
        """Push and tick once; whether the puck now rises.

        The wrench and the step request travel on different topics, in no order DDS keeps,
        and a new publisher's first sample can wait for its reader's discovery (seconds on a
        loaded machine): push again each tick until one arrives. From then on 100 N on
        2 kg (4.1 g up) turns any fall around within a few hundred ticks.
        """
        push.publish(wrench)
        assert sim.call('step_simulation', steps=1).result.result == OK
        return state_of(sim, 'puck')[2][2] > 0.0

    sim.until(pushed_up, 'the push held the puck up')
    assert sim.call('delete_entity', entity='puck').result.result == OK
    assert sim.call('get_entities').entities == ['box', 'plate']
    sim.until(lambda: sim.node.count_publishers(f'{sim.prefix}/puck/pose') == 0,
              'puck/pose gone')
    assert spawn(sim, 'puck', BALL, position=(0.0, 2.0, 0.0)).result.result == OK
    assert sim.call('step_simulation', steps=10).result.result == OK
    velocity = state_of(sim, 'puck')[2]
    np.testing.assert_allclose(velocity, [0.0, 0.0, -G * 10 * DT], atol=1e-12)


def test_simulate_steps_gives_feedback_per_step_and_can_be_cancelled(stopped):
    sim = stopped
    feedback = []
    goal = sim.action.send_goal_async(_goal(5), feedback_callback=feedback.append)
    sim.until(goal.done, 'goal answered')
    # Feedback is a topic and the result a service, so the last feedback may come after the
    # result, and rclpy's client drops a goal's feedback once it has its result: ask for the
    # result after the feedback, as a client that wants every step's does.
    sim.until(lambda: len(feedback) >= 5, 'five feedback messages')
    outcome = goal.result().get_result_async()
    sim.until(outcome.done, 'result')
    assert outcome.result().result.result.result == OK
    assert [(f.feedback.completed_steps, f.feedback.remaining_steps) for f in feedback] == [
        (n, 5 - n) for n in range(1, 6)]
    assert state_of(sim, 'box')[4] == pytest.approx(5 * DT, abs=1e-12)
    feedback.clear()
    goal = sim.action.send_goal_async(_goal(10 ** 6), feedback_callback=feedback.append)
    sim.until(lambda: len(feedback) >= 3, 'three steps')
    cancel = goal.result().cancel_goal_async()
    sim.until(cancel.done, 'cancel answered')
    outcome = goal.result().get_result_async()
    sim.until(outcome.done, 'cancelled result')
    assert outcome.result().status == GoalStatus.STATUS_CANCELED
    ran = state_of(sim, 'box')[4] / DT - 5
    assert len(feedback) <= round(ran) < 10 ** 6


def _goal(steps):
    return SimulateSteps.Goal(steps=steps)


def test_simulate_steps_runs_one_goal_at_a_time(stopped):
    """A second goal while one runs is rejected (each wakes the executor every 5 ms)."""
    sim = stopped
    running = sim.action.send_goal_async(_goal(10 ** 6))
    sim.until(running.done, 'first goal answered')
    assert running.result().accepted
    second = sim.action.send_goal_async(_goal(3))
    sim.until(second.done, 'second goal answered')
    assert not second.result().accepted
    cancel = running.result().cancel_goal_async()
    sim.until(cancel.done, 'cancel answered')
    outcome = running.result().get_result_async()
    sim.until(outcome.done, 'cancelled result')
    third = sim.action.send_goal_async(_goal(3))
    sim.until(third.done, 'third goal answered')
    assert third.result().accepted
    outcome = third.result().get_result_async()
    sim.until(outcome.done, 'result')
    assert outcome.result().result.result.result == OK


def test_simulate_steps_while_playing_is_aborted_as_operation_failed(stopped):
    sim, s = stopped, SimulationState
    assert sim.call('set_simulation_state', state=s(state=s.STATE_PLAYING)).result.result == OK
    goal = sim.action.send_goal_async(_goal(3))
    sim.until(goal.done, 'goal answered')
    outcome = goal.result().get_result_async()
    sim.until(outcome.done, 'result')
    assert outcome.result().result.result.result == Result.RESULT_OPERATION_FAILED


def test_reset_scopes(stopped):
    sim, scope = stopped, ResetSimulation.Request
    assert spawn(sim, 'ball', BALL).result.result == OK
    assert sim.call('step_simulation', steps=4).result.result == OK
    assert sim.call('reset_simulation', scope=scope.SCOPE_SPAWNED).result.result == OK
    assert sim.call('get_entities').entities == ['box', 'plate']
    position, _, _, _, time = state_of(sim, 'box')
    assert time == pytest.approx(4 * DT, abs=1e-12) and position[2] < 1.0
    assert sim.call('reset_simulation', scope=scope.SCOPE_TIME).result.result == OK
    after = state_of(sim, 'box')
    assert after[4] == 0.0 and after[0].tolist() == position.tolist()
    assert sim.call('reset_simulation', scope=scope.SCOPE_STATE).result.result == OK
    assert state_of(sim, 'box')[0].tolist() == [0.0, 0.0, 1.0]
    assert sim.call('delete_entity', entity='plate').result.result == OK
    assert sim.call('reset_simulation', scope=scope.SCOPE_DEFAULT).result.result == OK
    assert sim.call('get_entities').entities == ['box', 'plate']


def test_uri_spawns_a_scene_files_body_where_initial_pose_puts_it(stopped):
    """The file's frame goes to (5, 0, 0) turned 90 degrees about z: its (1, 0, 0) to (5, 1, 0).

    The body then falls under the running scene's gravity. A file of two bodies is one
    entity too many for SpawnEntity: refused, naming the count.
    """
    sim = stopped
    (sim.folder / 'pair.yaml').write_text("""
bodies:
  - {name: left, shape: {type: sphere, radius: 0.1}, mass: 1.0}
  - {name: right, shape: {type: sphere, radius: 0.1}, mass: 1.0}
""")
    answer = spawn(sim, uri='pair.yaml')
    assert answer.result.result == SpawnEntity.Response.RESOURCE_PARSE_ERROR
    assert '2 bodies' in answer.result.error_message
    one = sim.folder / 'one.yaml'
    one.write_text("""
bodies:
  - {name: right, shape: {type: sphere, radius: 0.1}, mass: 1.0,
     pose: {position: [1.0, 0.0, 0.0]}}
""")
    answer = spawn(sim, uri=f'file://{one}', position=(5.0, 0.0, 0.0), orientation=HALF_TURN_Z)
    assert (answer.result.result, answer.entity_name) == (OK, 'right')
    np.testing.assert_allclose(state_of(sim, 'right')[0], [5.0, 1.0, 0.0], atol=1e-12)
    assert sim.call('step_simulation', steps=10).result.result == OK
    assert state_of(sim, 'right')[0][2] == pytest.approx(-G * (10 * DT) ** 2 / 2, abs=1e-9)


def test_the_readme_spawn_example_prints_the_damped_fall(tmp_path):
    """The README's example, run as a user would against the node of the run command.

    Under gravity g and linear damping c = 0.05/s from rest: v = -(g / c)(1 - e^(-ct)),
    z = z0 - (g / c)(t - (1 - e^(-ct)) / c), at t = 10 ticks of 0.01 s.
    """
    readme = (ROOT / 'README.md').read_text()
    section = readme[readme.index('### Standard simulator interfaces'):]
    example = re.search(r'```python\n(.*?)```', section, re.S).group(1)
    (tmp_path / 'spawn.py').write_text(example)
    node = processes.start([str(EXECUTABLE)], cwd=tmp_path, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
    try:
        run = subprocess.run([sys.executable, 'spawn.py'], cwd=tmp_path, capture_output=True,
                             text=True, timeout=START_TIMEOUT)
    finally:
        node.send_signal(signal.SIGINT)
        node.wait(timeout=START_TIMEOUT)
    c, t = 0.05, 10 * DT
    v = -(G / c) * (1.0 - math.exp(-c * t))
    z = 2.0 - (G / c) * (t - (1.0 - math.exp(-c * t)) / c)
    assert run.stdout.splitlines() == ['spawned ball result 1', 'spawned can result 1',
                                       f'z {z:.5f} m, vz {v:.5f} m/s'], run.stderr
