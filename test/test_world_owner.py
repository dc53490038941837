# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Preparations that overlap: parameter changes, spawns, resets and reloads in every order.

Each race is forced, never timed: a gate holds the worker inside the preparation (the
integrator's compile, or a spawn's reading of its body) until the test has asked for the
other change, and the test drives the node's executor itself. The answers are what the
client was told; what must hold after is that what runs is what was asked for last, with
nothing answered OK and then lost: the integrator steps the world it was built for, and a
spawned body falls as a body under gravity g alone, ``g t^2 / 2`` from rest.
"""
import gc
import threading

from geometry_msgs.msg import WrenchStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from simulation_interfaces.msg import Result
from simulation_interfaces.srv import DeleteEntity, ResetSimulation, SpawnEntity

import ros_tools
from rigid_sim import conversions, node as node_module, spawning, world_owner
from rigid_sim.testing.delivery import wait_until

G = 9.81
DT = 0.01
SCENE = f"""
limits: {{max_bodies: 4}}
effects: {{gravity: {{acceleration: [0.0, 0.0, -{G}]}}}}
bodies:
  - {{name: box, shape: {{type: box, size: [0.2, 0.2, 0.2]}}, mass: 1.0,
     pose: {{position: [0.0, 0.0, 1.0]}}}}
"""
HEIGHT = 9.0   # m, where the ball is spawned, at rest
BALL = ('{name: ball, shape: {type: sphere, radius: 0.1}, mass: 2.0, '
        f'pose: {{position: [3.0, 0.0, {HEIGHT}]}}}}')
OTHER = SCENE.replace('name: box', 'name: crate')
WAIT = 600.0   # s of wall time a preparation may take at most (a compile on a loaded machine)


class Gate:
    """Holds the first worker that calls the wrapped function until :meth:`open`."""

    def __init__(self):
        self.entered, self._open = threading.Event(), threading.Event()

    def wrap(self, function):
        def gated(*args, **kwargs):
            if not self.entered.is_set():
                self.entered.set()
                assert self._open.wait(WAIT), 'the test never opened the gate'
            return function(*args, **kwargs)
        return gated

    def open(self):
        self._open.set()


@pytest.fixture
def sim(rigid_sim):
    return rigid_sim(yaml=SCENE, time_step=DT, start_paused=True)


def spin_until(sim, condition, what):
    assert wait_until(sim.executor, condition, WAIT), f'never: {what}'


def ask_spawn(sim):
    """Ask for the ball as ~/spawn_entity does; the list its answer is appended to."""
    answers = []
    answer = sim.node.sim_interfaces.spawns._on_spawn(
        SpawnEntity.Request(resource_string=BALL), SpawnEntity.Response(), answers.append)
    assert answer is spawning.deferred.LATER   # prepared off the executor, answered later
    return answers


def spawn_past(sim, gate):
    """Ask for the ball while ``gate`` holds another preparation, open it; assert it spawned."""
    answers = ask_spawn(sim)
    spin_until(sim, lambda: answers or waits_its_turn(sim), 'spawn answered or queued')
    gate.open()
    finish(sim)
    assert answers[0].result.result == Result.RESULT_OK


def ask_reset(sim, scope):
    answers = []
    sim.node.sim_interfaces._on_reset(ResetSimulation.Request(scope=scope),
                                      ResetSimulation.Response(), answers.append)
    return answers


def waits_its_turn(sim):
    """Whether the node has queued a preparation behind the one running (it has an owner)."""
    owner = getattr(sim.node, 'owner', None)
    return owner is not None and owner.busy


def finish(sim):
    """Drive the executor until every preparation is swapped in or refused."""
    node = sim.node
    for _ in range(3):   # one may start another once it ends
        assert node.reconfiguration.wait(WAIT) and node.sim_interfaces.editor.wait(WAIT)
    sim.settle()


def gate_prepare(sim):
    gate, node = Gate(), sim.node
    node.prepare = gate.wrap(node.prepare)   # the integrator's or the scene's preparation
    return gate


def gate_spawn(monkeypatch):
    gate = Gate()
    monkeypatch.setattr(spawning, 'entry_from_text', gate.wrap(spawning.entry_from_text))
    return gate


def assert_runs(sim, integrator, bodies):
    """Assert the world has ``bodies``, stepped by an ``integrator`` built for it."""
    world = sim.node.world
    assert world.bodies.names == bodies
    assert sim.node.settings.integrator == integrator == world.integrator.name
    # An integrator built for another world indexes bodies that are not there.
    assert world.integrator.bodies is world.bodies


def assert_ball_falls(sim):
    """From rest at HEIGHT under gravity alone: z = HEIGHT - g t^2 / 2 (exact for rk4)."""
    index = sim.node.world.bodies.names.index('ball')
    start = sim.node.world.time
    ticks = 10
    sim.step(ticks)
    elapsed = sim.node.world.time - start
    assert elapsed == pytest.approx(ticks * DT)
    z = sim.node.world.y[index, 2]
    assert z == pytest.approx(HEIGHT - 0.5 * G * elapsed ** 2, abs=1e-9)


def test_a_spawn_during_an_integrator_compile_runs_the_new_integrator_on_the_new_world(
        sim, monkeypatch):
    """The compile ends after the spawn was asked: the integrator is made for the new world."""
    gate = Gate()   # held in the compile, after the integrator was made for the world
    monkeypatch.setattr(node_module, 'warm_up', gate.wrap(node_module.warm_up))
    assert sim.node.set_parameters([Parameter('integrator', value='rk4')])[0].successful
    assert gate.entered.wait(WAIT)          # compiling, held
    spawn_past(sim, gate)
    assert_runs(sim, 'rk4', ('box', 'ball'))
    sim.resume()
    assert_ball_falls(sim)


def test_parameters_set_during_a_spawn_are_what_runs_after_it(sim, monkeypatch):
    """Integrator and error control changed while the spawn reads its body: neither is lost."""
    gate = gate_spawn(monkeypatch)
    answers = ask_spawn(sim)
    assert gate.entered.wait(WAIT)          # the spawn's worker is inside, held
    node = sim.node
    assert all(result.successful for result in node.set_parameters(
        [Parameter('integrator', value='rk4'), Parameter('error_control', value=False)]))
    # The integrator is swapped into the running world first, or waits for the spawn.
    spin_until(sim, lambda: node.world.integrator.name == 'rk4' or waits_its_turn(sim),
               'the integrator swapped in or queued')
    gate.open()
    finish(sim)
    assert answers[0].result.result == Result.RESULT_OK
    assert_runs(sim, 'rk4', ('box', 'ball'))
    assert node.world.control.error_control is False
    sim.resume()
    assert_ball_falls(sim)


def test_removing_spawned_bodies_while_a_spawn_is_pending_removes_that_one_too(
        sim, monkeypatch):
    gate = gate_spawn(monkeypatch)
    spawned = ask_spawn(sim)
    assert gate.entered.wait(WAIT)
    reset = ask_reset(sim, ResetSimulation.Request.SCOPE_SPAWNED)
    sim.settle()
    gate.open()
    finish(sim)
    assert spawned[0].result.result == Result.RESULT_OK
    assert reset[0].result.result == Result.RESULT_OK
    assert sim.node.world.bodies.names == ('box',)   # the reset came after the spawn


def test_a_spawn_asked_during_a_scene_reload_is_made_in_the_reloaded_scene(sim, tmp_path):
    """Answered OK means the body is there: it is not lost to the reload asked before it."""
    other = tmp_path / 'other.yaml'
    other.write_text(OTHER)
    gate = gate_prepare(sim)
    assert sim.node.set_parameters([Parameter('scene', value=str(other))])[0].successful
    assert gate.entered.wait(WAIT)          # loading, held
    spawn_past(sim, gate)
    assert sim.node.world.bodies.names == ('crate', 'ball')
    sim.resume()
    assert_ball_falls(sim)


def test_a_spawn_after_a_scene_set_twice_is_not_lost_to_the_second_load(sim, tmp_path):
    """The scene set again while it loads is loaded before the spawn asked after both.

    Found by a client setting ``scene`` and spawning in turn: the second load went behind
    the spawns queued meanwhile, so bodies answered OK vanished with it.
    """
    other = tmp_path / 'other.yaml'
    other.write_text(OTHER)
    gate = gate_prepare(sim)
    assert sim.node.set_parameters([Parameter('scene', value=str(other))])[0].successful
    assert gate.entered.wait(WAIT)          # loading, held
    assert sim.node.set_parameters([Parameter('scene', value=str(other))])[0].successful
    spawn_past(sim, gate)
    assert sim.node.world.bodies.names == ('crate', 'ball')


def test_a_spawn_asked_before_a_parameter_is_set_again_is_not_held_behind_it(sim):
    """A flood of parameter sets must not starve an edit asked before them.

    The tolerance set again while its preparation runs is queued then, behind the spawn
    already waiting: the spawn is made before that second preparation begins.
    """
    node, order, answers = sim.node, [], []
    gate = gate_prepare(sim)
    held = node.prepare

    def prepare(*args):
        order.append('prepare')
        return held(*args)

    def answered(response):
        order.append('spawned')
        answers.append(response)
    node.prepare = prepare
    assert node.set_parameters([Parameter('tolerance', value=1e-7)])[0].successful
    assert gate.entered.wait(WAIT)          # preparing, held
    node.sim_interfaces.spawns._on_spawn(SpawnEntity.Request(resource_string=BALL),
                                         SpawnEntity.Response(), answered)
    assert node.set_parameters([Parameter('tolerance', value=2e-7)])[0].successful
    gate.open()
    finish(sim)
    assert order == ['prepare', 'spawned', 'prepare']
    assert answers[0].result.result == Result.RESULT_OK
    assert node.settings.tolerance == 2e-7 and node.world.bodies.names == ('box', 'ball')


def test_a_stale_preparation_is_begun_again_from_what_runs(sim, monkeypatch):
    """A setting applied to the running world while a spawn is built stales the spawn."""
    gate = gate_spawn(monkeypatch)
    answers = ask_spawn(sim)
    assert gate.entered.wait(WAIT)
    generation = sim.node.owner.generation
    assert sim.node.set_parameters([Parameter('error_control', value=False)])[0].successful
    assert sim.node.owner.generation == generation + 1
    gate.open()
    finish(sim)
    assert sim.node.owner.redone == 1 and sim.node.owner.generation == generation + 2
    assert answers[0].result.result == Result.RESULT_OK
    assert sim.node.world.control.error_control is False


def test_a_scene_edit_builds_the_output_messages_off_the_executor(sim, monkeypatch):
    """The swap between two ticks makes no per-body message: that is O(bodies) work."""
    made_on = []
    build = conversions.StateMessages

    def recorded(*args, **kwargs):
        made_on.append(threading.current_thread())
        return build(*args, **kwargs)
    monkeypatch.setattr(conversions, 'StateMessages', recorded)
    answers = ask_spawn(sim)
    finish(sim)
    assert answers[0].result.result == Result.RESULT_OK
    assert made_on and threading.main_thread() not in made_on


def test_refused_input_counts_outlive_scene_edits(sim):
    probe = ros_tools.Probe(sim, 'box')
    probe.push('box', 'nowhere', force=(1.0, 0.0, 0.0))   # an unknown frame: refused
    sim.step(1)
    assert probe.diagnostics.values()['refused inputs box'] == '1'
    answers = ask_spawn(sim)
    finish(sim)
    assert answers[0].result.result == Result.RESULT_OK
    values = probe.diagnostics.values()
    assert values['refused inputs box'] == '1' and values['refused inputs'] == '1'


def test_diagnostics_say_paused_while_paused(sim):
    probe = ros_tools.Probe(sim)
    sim.step(1)
    assert probe.diagnostics.now().message == 'paused'
    sim.resume()
    sim.step(1)
    assert probe.diagnostics.now().message == 'running'
    assert np.isfinite(sim.node.world.y).all()


def test_a_reload_forgets_the_spawned_bodies_for_resets(sim, tmp_path):
    """After a reload the scene's own body of a spawned body's name is not 'spawned'."""
    answers = ask_spawn(sim)
    finish(sim)
    assert answers[0].result.result == Result.RESULT_OK
    with_ball = tmp_path / 'with_ball.yaml'
    with_ball.write_text(OTHER + '  - ' + BALL + '\n')
    assert sim.set_parameters(scene=str(with_ball))[0].successful
    assert sim.node.world.bodies.names == ('crate', 'ball')
    reset = ask_reset(sim, ResetSimulation.Request.SCOPE_SPAWNED)
    finish(sim)
    assert reset[0].result.result == Result.RESULT_OK
    assert sim.node.world.bodies.names == ('crate', 'ball')


def test_deleting_a_body_whose_spawn_is_pending_deletes_it_after_the_spawn(sim, monkeypatch):
    gate = gate_spawn(monkeypatch)
    spawned = ask_spawn(sim)
    assert gate.entered.wait(WAIT)
    deleted = []
    at_once = sim.node.sim_interfaces.spawns._on_delete(
        DeleteEntity.Request(entity='ball'), DeleteEntity.Response(), deleted.append)
    assert at_once is spawning.deferred.LATER, 'answered before the spawn it follows'
    sim.settle()
    gate.open()
    finish(sim)
    assert spawned[0].result.result == Result.RESULT_OK
    assert deleted[0].result.result == Result.RESULT_OK
    assert sim.node.world.bodies.names == ('box',)
    missing = sim.node.sim_interfaces.spawns._on_delete(   # nothing pending: answered now
        DeleteEntity.Request(entity='ball'), DeleteEntity.Response(), None)
    assert missing.result.result == Result.RESULT_NOT_FOUND


TWO = """
bodies:
  - {name: a, shape: {type: box, size: [0.2, 0.2, 0.2]}, mass: 1.0}
  - {name: b, shape: {type: box, size: [0.2, 0.2, 0.2]}, mass: 2.0,
     pose: {position: [5.0, 0.0, 0.0]}}
"""


def test_a_kept_body_keeps_its_topics_across_edits_and_its_wrench_follows_it(rigid_sim):
    """A spawn or delete makes and destroys the topics of the bodies it adds or removes only.

    Remaking every body's topics at each swap held control 0.1-0.7 s per spawn in a flood.
    b's wrench subscription outlives the spawn of ball and the delete of a, which moves b
    from index 1 to 0, and its wrench still pushes b alone: F / m = 1 m/s^2 for 0.1 s.
    """
    sim = rigid_sim(yaml=TWO, time_step=DT, start_paused=True, wrench_timeout=0.0)
    node = sim.node
    listened = node.inputs._subscribed[('wrench', 'b')][0]
    published = list(node.outputs._bodies[1])
    answers = []
    node.sim_interfaces.spawns._on_spawn(SpawnEntity.Request(resource_string=BALL),
                                         SpawnEntity.Response(), answers.append)
    node.sim_interfaces.spawns._on_delete(DeleteEntity.Request(entity='a'),
                                          DeleteEntity.Response(), answers.append)
    finish(sim)
    assert [answer.result.result for answer in answers] == [Result.RESULT_OK] * 2
    assert node.world.bodies.names == ('b', 'ball')
    assert node.inputs._subscribed[('wrench', 'b')][0] is listened
    assert node.outputs._bodies[0] == published
    push = sim.create_node('pusher').create_publisher(WrenchStamped, sim.topic('b/wrench'), 10)
    wrench = WrenchStamped()
    wrench.header.frame_id = 'world'
    wrench.wrench.force.x = 2.0
    push.publish(wrench)
    sim.resume()
    sim.step(10)
    np.testing.assert_allclose(sim.state('b').velocity, [0.1, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(sim.state('ball').velocity, [0.0, 0.0, 0.0], atol=1e-12)


def test_edits_past_the_queue_bound_are_refused_at_once_and_the_queued_ones_run(
        sim, monkeypatch):
    """A flood of spawns queues at most MAX_PENDING_EDITS; the next is refused, not held.

    Each queued edit holds its request and, prepared, a new scene: an unbounded queue grows
    with what a client sends. The ones queued are all answered and spawned.
    """
    gate = gate_spawn(monkeypatch)
    monkeypatch.setattr(spawning, 'MAX_PENDING_EDITS', 3)   # bodies are limited to 4
    spawns = sim.node.sim_interfaces.spawns
    queued = []
    for number in range(3):
        request = SpawnEntity.Request(resource_string=BALL.replace('ball', f'ball{number}'))
        answers = []
        assert spawns._on_spawn(request, SpawnEntity.Response(), answers.append) is \
            spawning.deferred.LATER
        queued.append(answers)
    spin_until(sim, gate.entered.is_set, 'the first spawn is prepared')
    refused = spawns._on_spawn(SpawnEntity.Request(resource_string=BALL),
                               SpawnEntity.Response(), None)
    assert refused.result.result == Result.RESULT_OPERATION_FAILED
    assert '3 scene edits are pending' in refused.result.error_message
    deleted = spawns._on_delete(DeleteEntity.Request(entity='box'), DeleteEntity.Response(),
                                None)
    assert deleted.result.result == Result.RESULT_OPERATION_FAILED
    gate.open()
    finish(sim)
    assert [answers[0].result.result for answers in queued] == [Result.RESULT_OK] * 3
    assert sim.node.world.bodies.names == ('box', 'ball0', 'ball1', 'ball2')


@pytest.fixture
def frozen_heap(sim):
    """Run the owner of ``sim`` as rigid_sim_node does (spin.run); put the collector back."""
    sim.node.owner.keeps_heap_frozen = True
    yield sim.node.owner
    gc.enable()
    gc.unfreeze()


def spawn_and_delete(sim):
    answers = ask_spawn(sim)
    finish(sim)
    sim.node.sim_interfaces.spawns._on_delete(DeleteEntity.Request(entity='ball'),
                                              DeleteEntity.Response(), answers.append)
    finish(sim)
    assert [answer.result.result for answer in answers] == [Result.RESULT_OK] * 2


def test_a_scene_edit_is_built_with_the_collector_off_and_frozen_once_swapped_in(
        sim, frozen_heap, monkeypatch):
    """A full collection walks every object not frozen, under the interpreter lock."""
    gate = gate_spawn(monkeypatch)
    before = gc.get_freeze_count()
    answers = ask_spawn(sim)
    assert gate.entered.wait(WAIT)
    assert not gc.isenabled()   # while the worker builds the scene
    gate.open()
    finish(sim)
    assert answers[0].result.result == Result.RESULT_OK
    assert gc.isenabled()
    assert gc.get_freeze_count() > before   # the ball's objects among them
    sim.resume()
    assert_ball_falls(sim)


def test_the_garbage_frozen_scene_edits_leave_is_collected_every_so_many_swaps(
        sim, frozen_heap, monkeypatch):
    """Frozen garbage, the cycles among what swaps replaced, is collected now and then.

    The rest is freed by reference counts; the cycles (~35 objects an edit here) stay
    frozen until a full collection every SWAPS_PER_COLLECTION swaps.
    """
    def growth(cycles):
        spawn_and_delete(sim)
        once = gc.get_freeze_count()
        for _ in range(cycles):
            spawn_and_delete(sim)
        return gc.get_freeze_count() - once

    monkeypatch.setattr(world_owner, 'SWAPS_PER_COLLECTION', 10 ** 6)
    uncollected = growth(12)
    monkeypatch.setattr(world_owner, 'SWAPS_PER_COLLECTION', 4)   # 2 spawns and deletes
    assert growth(12) < uncollected / 2
