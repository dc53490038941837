# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Bounded work per executor round: long ticks in slices, capped steps, a flood of goals.

Control is answered between two executor callbacks, so every callback must end after a
bounded amount of work, whatever was asked. Nothing here is timed: each test asserts what
the work was (world steps taken by one call, attempts of a capped step, solves made).
"""
import threading

import numpy as np

import test_node_error_estimates as rod
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rigid_sim import goal_input, tick_loop
from rigid_sim.core.integrators.adaptive import MAX_INTERNAL_STEPS
from rigid_sim.core.scene import build_world, load_scene
from rigid_sim.core.text import SHOWN_CHARACTERS, shown
from rigid_sim.tick_loop import StepJob, TickLoop
from ros_tools import record, spin_until
from test_goal_node import DT, SCENE, User, values
from test_tick_loop import FakeNode

SUBSTEPS = 40
# The thin rod 100 times faster: 10 000 rad/s about its middle axis. Held to 1e-12, dopri5
# takes over 3000 internal steps in 0.01 s.
FAST_ROD = rod.ROD.replace('[0.0, 100.0, 0.1]', '[0.0, 10000.0, 10.0]')
TIMEOUT = 120.0   # s: a liveness bound for the worker thread on a loaded machine


class QuotedWhole(str):
    """Outside text that fails the test if a refusal quotes it whole (repr of all of it)."""

    def __repr__(self):
        raise AssertionError(f'repr of all {len(self)} characters')


def test_a_refusal_quotes_only_the_ends_of_a_long_text():
    """A 300 MB frame_id's repr took 1.1 s: only its ends are quoted, then its length."""
    text = QuotedWhole('a' + '\n' * 1_000_000 + 'z')
    quoted = shown(text)
    assert len(quoted) < SHOWN_CHARACTERS + 40
    assert quoted.startswith("'a\\n\\n") and quoted.endswith("\\n\\nz'")
    assert '...(1000002 characters)...' in quoted


def test_a_tick_told_its_slice_is_over_stops_after_one_step_and_goes_on_later(rigid_sim):
    """A deadline already passed: each call takes one world step; the last ends the tick."""
    sim = rigid_sim(yaml=SCENE, time_step=DT, substeps=SUBSTEPS)
    node = sim.node
    times = [node.world.time]
    for _ in range(SUBSTEPS - 1):
        assert node._tick(True, until=0.0) is False
        times.append(node.world.time)
        assert node.ticks == 0   # not published, not counted: the tick is not done
    assert node._tick(True, until=0.0) is True
    times.append(node.world.time)
    assert node.ticks == 1
    steps = np.diff(times)
    assert np.all(steps > 0.0) and np.allclose(steps, DT / SUBSTEPS, rtol=1e-9)
    assert np.isclose(node.world.time, DT, rtol=1e-12)


def test_a_reset_between_two_slices_drops_the_rest_of_the_tick(rigid_sim):
    sim = rigid_sim(yaml=SCENE, time_step=DT, substeps=SUBSTEPS)
    node = sim.node
    assert node._tick(True, until=0.0) is False
    node.reset()
    assert node._tick(True, until=0.0) is True   # the remaining steps were for the old run
    assert node.world.time == 0.0 and node.ticks == 1


class SlicedTicks:
    """Ticks that each take ``slices`` calls: not done until the last of them."""

    def __init__(self, slices):
        self.slices, self.calls, self.done = slices, 0, 0

    def __call__(self, advance, until):
        self.calls += 1
        if self.calls % self.slices:
            return False
        self.done += 1
        return True


def test_the_loop_counts_a_tick_in_slices_once_it_is_done():
    """A step job of 2 ticks, each taking 3 slices: 6 rounds, answered with 2 ticks."""
    ticks = SlicedTicks(3)
    node = FakeNode()
    loop = TickLoop(node, ticks, rate=0.0)
    loop.set_paused(True)
    answers = []
    loop.run_job(StepJob(2, lambda ran, why: answers.append((ran, why))))
    rounds = 0
    while not node.timers[1].canceled:
        node.timers[1].callback()
        rounds += 1
        assert rounds <= 6
    assert answers == [(2, '')] and ticks.calls == 6 and ticks.done == 2


def test_a_catch_up_stops_at_a_tick_in_slices_and_resumes_it(monkeypatch):
    """At a wall rate an unfinished tick ends the wake-up; the next one finishes it first."""
    now = [0.0]
    monkeypatch.setattr(tick_loop, 'monotonic', lambda: now[0])
    ticks = SlicedTicks(2)
    node = FakeNode()
    TickLoop(node, ticks, rate=100.0)
    now[0] += 0.01
    node.timers[0].callback()
    assert (ticks.calls, ticks.done) == (1, 0)
    node.timers[0].callback()
    assert ticks.done == 1


def test_dopri5_far_below_its_reach_gives_the_step_up_as_capped_in_one_attempt(write_scene):
    """Tolerance 1e-12 on the fast rod: the step is given up, the state kept, one attempt.

    Unbounded, it takes thousands of internal steps; more pieces would not help.
    """
    assert FAST_ROD != rod.ROD
    world = build_world(load_scene(write_scene(FAST_ROD)), 'dopri5', 1e-12, True)
    before = world.y.copy()
    assert world.step(0.01) is False
    diagnostics = world.diagnostics
    assert 'capped at' in diagnostics.last_failure and 'internal steps' in diagnostics.last_failure
    assert diagnostics.rejected_steps == 1 and diagnostics.failed_steps == 1
    assert np.array_equal(world.y, before) and world.time == 0.0
    assert world.integrator.cap <= MAX_INTERNAL_STEPS


def test_capped_error_control_is_a_warning_with_its_numbers(rigid_sim):
    """Euler at 1e-12 on the thin rod: capped substeps, estimate far above the tolerance."""
    sim = rigid_sim(yaml=rod.ROD, integrator='euler', tolerance=1e-12, time_step=0.01)
    probe = sim.create_node('capped_probe')
    heard = record(probe, DiagnosticArray, '/diagnostics')
    sim.step(3)
    why = sim.node.world.diagnostics.why
    assert why.capped and sim.node.world.diagnostics.error_estimate > 1e-12
    sim.node.publish_diagnostics()
    spin_until(sim.executor, lambda: [a for a in heard if 'physics' in a.status[0].name],
               what='/diagnostics')
    status = [a for a in heard if 'physics' in a.status[0].name][-1].status[0]
    assert status.level == DiagnosticStatus.WARN
    assert 'error control capped' in status.message and 'tolerance 1e-12' in status.message


class GatedSolver(goal_input.GoalSolver):
    """The worker's solves counted; the first one held until ``gate`` opens."""

    entered, gate = threading.Event(), threading.Event()
    worker_solves = 0

    def solve(self, goal, path=False, **options):
        if not path:   # the worker's (the tick asks for the path)
            type(self).worker_solves += 1
            type(self).entered.set()
            assert type(self).gate.wait(TIMEOUT)
        return super().solve(goal, path, **options)


def test_a_flood_of_goals_solves_the_latest_and_reports_the_rest_superseded(
        rigid_sim, monkeypatch):
    """Twenty goals while the worker is busy: one waits at a time, only the last is solved."""
    monkeypatch.setattr(goal_input, 'WORST_FLIGHTS', 10 ** 9)   # every solve in the worker
    monkeypatch.setattr(goal_input, 'GoalSolver', GatedSolver)
    sim = rigid_sim(yaml=SCENE, time_step=DT)
    sim.node.loop.stopped = False   # as if a wall clock ticked it: solves go to the thread
    user = User(sim)
    user.goal(at=2.0)
    sim.step(1)
    assert GatedSolver.entered.wait(TIMEOUT)   # the first goal is being solved
    flood = 20
    for k in range(flood):
        user.goal(at=2.0 + k * DT)
        sim.step(1)
    goals = sim.node.goals
    assert len(goals._jobs._waiting) == 1   # one body, one goal waiting: bounded
    assert goals.superseded == flood
    GatedSolver.gate.set()
    spin_until(sim.executor, lambda: goals._results.qsize() == 2, TIMEOUT,
               "the worker's two outcomes")
    sim.step(1)
    assert GatedSolver.worker_solves == 2   # the one under way and the latest; none between
    solved = [s for s in user.statuses if s.message.startswith('goal solved')]
    assert len(solved) == 1 and values(solved[-1])['goal time [s]'] == repr(2.0 + 19 * DT)
    superseded = [s for s in user.statuses if s.message.startswith('goal superseded')]
    assert len(superseded) == flood and superseded[-1].level == DiagnosticStatus.WARN


def test_a_springs_goal_with_a_wall_clock_is_solved_off_the_tick(rigid_sim):
    """The packaged springs scene, a goal 2 s ahead: its worst case is above the bound.

    200 steps, once few enough to be solved in the tick, where it held /clock up for
    seconds: the tick now hands it to the worker and returns; the answer comes later.
    """
    sim = rigid_sim(scene='springs.yaml', time_step=DT)
    sim.node.loop.stopped = False   # as if a wall clock ticked it
    user = User(sim, 'bob')
    user.goal(at=2.0)
    sim.step(1)
    goals = sim.node.goals
    assert (goals.solved, goals.refused, list(goals._latest)) == (0, 0, [0])
    spin_until(sim.executor, lambda: goals._results.qsize() == 1, TIMEOUT,
               "the worker's outcome")
    sim.step(1)
    assert goals.solved + goals.refused == 1
    assert 'worker thread' in values(user.statuses[-1]).get('solved in', 'worker thread')


THREE = """
bodies:
  - {name: a, shape: {type: sphere, radius: 0.1}, mass: 1.0, pose: {position: [1.0, 0.0, 0.0]}}
  - {name: b, shape: {type: sphere, radius: 0.1}, mass: 1.0, pose: {position: [2.0, 0.0, 0.0]}}
  - {name: c, shape: {type: sphere, radius: 0.1}, mass: 1.0, pose: {position: [3.0, 0.0, 0.0]}}
"""


def test_get_entities_states_refuses_more_states_than_one_answer_may_carry(rigid_sim):
    """An answer of more states than max_answer_states is refused with the count, not cut."""
    from simulation_interfaces.msg import EntityFilters, Result
    from simulation_interfaces.srv import GetEntitiesStates
    sim = rigid_sim(yaml=THREE, rate=0.0, start_paused=True, max_answer_states=3)
    sim.set_parameters(max_answer_states=2)   # lowered at runtime, raised back below

    def states(pattern=''):
        request = GetEntitiesStates.Request(filters=EntityFilters(filter=pattern))
        return sim.call(GetEntitiesStates, 'get_entities_states', request)

    refused = states()
    assert refused.result.result == Result.RESULT_OPERATION_FAILED
    assert '3 entities match' in refused.result.error_message
    assert 'max_answer_states = 2' in refused.result.error_message
    assert list(refused.entities) == [] and list(refused.states) == []
    two = states('^[ab]$')
    assert two.result.result == Result.RESULT_OK
    assert [s.pose.position.x for s in two.states] == [1.0, 2.0]
    sim.set_parameters(max_answer_states=3)
    assert [s.pose.position.x for s in states().states] == [1.0, 2.0, 3.0]


MANY = 'bodies:\n' + ''.join(
    f'  - {{name: s{i}, shape: {{type: sphere, radius: 0.1}}, mass: 1.0, '
    f'pose: {{position: [{i}.0, 0.0, 0.0]}}}}\n' for i in range(1000))


def test_answers_in_the_making_are_bounded_and_one_more_is_refused(rigid_sim, monkeypatch):
    """Each answer built in slices holds a snapshot of every body: past the bound, refused.

    Every answer goes to slices here (a slice of 1 us: eight rounds for 1000 bodies), with a
    bound of 2 (64 in the node): of four calls sent at once, the first two are answered in
    full and the last two refused at once, saying why.
    """
    from rigid_sim.deferred import SERVICE_QOS
    from simulation_interfaces.msg import Result
    from simulation_interfaces.srv import GetEntitiesStates
    monkeypatch.setattr('rigid_sim.entity_services.SLICE', 1e-6)
    monkeypatch.setattr('rigid_sim.entity_services.MAX_BUILDING', 2)
    sim = rigid_sim(yaml=MANY, rate=0.0, start_paused=True)
    client = sim.create_node('client').create_client(
        GetEntitiesStates, sim.topic('get_entities_states'), qos_profile=SERVICE_QOS)
    spin_until(sim.executor, client.service_is_ready, what='service get_entities_states')
    calls = [client.call_async(GetEntitiesStates.Request()) for _ in range(4)]
    spin_until(sim.executor, lambda: all(call.done() for call in calls),
               what='every call answered', timeout=TIMEOUT)
    answers = [call.result() for call in calls]
    assert [len(a.states) for a in answers[:2]] == [1000, 1000]
    assert all(a.result.result == Result.RESULT_OK for a in answers[:2])
    for refused in answers[2:]:
        assert refused.result.result == Result.RESULT_OPERATION_FAILED
        assert 'answers are being built or sent, at most 2 at once' in refused.result.error_message
        assert list(refused.states) == [] and list(refused.entities) == []


def test_answers_built_but_not_yet_sent_count_against_the_bound(rigid_sim, monkeypatch):
    """An answer holds its states until sent: built but unsent, it still takes a place.

    The sending thread is held at its first answer. With a bound of 2, two answers built
    (one held in the send, one waiting for it) leave no place: a third call is refused at
    once, saying why, and the two are answered in full once the send is let go.
    """
    from rigid_sim import deferred
    from rigid_sim.deferred import SERVICE_QOS
    from simulation_interfaces.msg import Result
    from simulation_interfaces.srv import GetEntitiesStates
    monkeypatch.setattr('rigid_sim.entity_services.SLICE', 1e-6)
    monkeypatch.setattr('rigid_sim.entity_services.MAX_BUILDING', 2)
    held, go = threading.Event(), threading.Event()
    deliver = deferred.Reply._deliver

    def held_deliver(reply):
        held.set()
        go.wait(TIMEOUT)
        deliver(reply)

    monkeypatch.setattr(deferred.Reply, '_deliver', held_deliver)
    sim = rigid_sim(yaml=MANY, rate=0.0, start_paused=True)
    client = sim.create_node('client').create_client(
        GetEntitiesStates, sim.topic('get_entities_states'), qos_profile=SERVICE_QOS)
    spin_until(sim.executor, client.service_is_ready, what='service get_entities_states')
    calls = [client.call_async(GetEntitiesStates.Request()) for _ in range(2)]
    spin_until(sim.executor, held.is_set, what='the first answer held in its send')
    spin_until(sim.executor, lambda: sim.node.sim_interfaces.entities._builds.idle,
               what='the second answer built')
    third = client.call_async(GetEntitiesStates.Request())
    spin_until(sim.executor, third.done, what='the third call answered')
    refused = third.result()
    assert refused.result.result == Result.RESULT_OPERATION_FAILED
    assert '2 answers are being built or sent, at most 2 at once' in refused.result.error_message
    assert not any(call.done() for call in calls)
    go.set()
    spin_until(sim.executor, lambda: all(call.done() for call in calls),
               what='both held answers sent', timeout=TIMEOUT)
    assert [len(call.result().states) for call in calls] == [1000, 1000]


def test_the_goal_and_answer_threads_end_with_their_node(rigid_sim, monkeypatch):
    """A node destroyed leaves none of its threads behind: a suite makes nodes by the hundred.

    The worker solves a goal (a wall clock sends it there) and a GetEntitiesStates answer
    built in slices is sent by the answering thread; once the node is closed both end.
    """
    from rigid_sim.deferred import SERVICE_QOS
    from simulation_interfaces.srv import GetEntitiesStates
    monkeypatch.setattr('rigid_sim.entity_services.SLICE', 1e-6)
    earlier = set(threading.enumerate())
    sim = rigid_sim(yaml=MANY, time_step=DT)
    client = sim.create_node('client').create_client(
        GetEntitiesStates, sim.topic('get_entities_states'), qos_profile=SERVICE_QOS)
    spin_until(sim.executor, client.service_is_ready, what='service get_entities_states')
    call = client.call_async(GetEntitiesStates.Request())
    spin_until(sim.executor, call.done, what='the answer of 1000 states', timeout=TIMEOUT)
    assert len(call.result().states) == 1000
    sim.node.loop.stopped = False   # as if a wall clock ticked it: solves go to the thread
    User(sim, 's0').goal(at=2.0)
    names = ('rigid_sim goals', 'entities answer')

    def threads():
        return [t for t in set(threading.enumerate()) - earlier if t.name.startswith(names)]
    while sorted(t.name[:15] for t in threads()) != ['entities answer', 'rigid_sim goals']:
        assert sim.time < 1.0, f'threads: {[t.name for t in threads()]}'
        sim.step(1)
    started = threads()
    sim.close()
    for thread in started:
        thread.join(TIMEOUT)
        assert not thread.is_alive(), thread.name
