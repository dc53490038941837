# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The fixed-rate loop: simulated time locked to wall time, catch-up, overrun reported.

The loop reads the wall clock through ``monotonic``; here a fake clock stands in for
it, so the schedule is checked exactly, without waiting: tick k is due k / rate seconds
after the first, and after any sequence of late wake-ups the loop has run every tick due.
"""
import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from rigid_sim import tick_loop
from rigid_sim.tick_loop import MAX_LAG, TickLoop

RATE = 1000.0  # Hz


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class FakeTimer:
    def __init__(self, callback):
        self.callback = callback
        self.canceled = False
        self.resets = 0

    def cancel(self):
        self.canceled = True

    def reset(self):
        self.canceled = False
        self.resets += 1

    def is_canceled(self):
        return self.canceled


class FakeNode:
    def __init__(self):
        self.timers = []

    def create_timer(self, period, callback, clock):
        self.timers.append(FakeTimer(callback))
        return self.timers[-1]


@pytest.fixture
def clock(monkeypatch):
    fake = FakeClock()
    monkeypatch.setattr(tick_loop, 'monotonic', fake)
    return fake


def make_loop(rate=RATE, tick=None):
    """Return the loop, its wall timer's callback, and the ticks run (each one's advance)."""
    ticks = []
    node = FakeNode()
    loop = TickLoop(node, tick or (lambda advance, until: ticks.append(advance)), rate)
    return loop, node.timers[0].callback, ticks


def test_late_wake_ups_are_caught_up_so_ticks_follow_wall_time(clock):
    """Ticks catch up after late wake-ups, so simulated time never drifts from wall time.

    Wake-ups come at jittered times up to 20 periods late; after each, the ticks run equal
    the ticks due, floor(elapsed x rate) + 1.
    """
    start = clock.now + 1.0 / RATE   # the first tick is due one period after the start
    loop, wake, ticks = make_loop()
    rng = np.random.default_rng(5)
    for late in rng.uniform(0.0, 20.0 / RATE, size=500).cumsum():
        clock.now = start + late
        wake()
        assert len(ticks) == math.floor(late * RATE) + 1
    assert loop.take_dropped() == 0


def test_an_early_or_repeated_wake_up_runs_no_tick_twice(clock):
    """Two wake-ups within one period run the due tick once."""
    loop, wake, ticks = make_loop()
    clock.now += 1.5 / RATE
    wake()
    wake()
    assert len(ticks) == 1


def test_falling_behind_by_more_than_the_bound_gives_ticks_up_and_counts_them(clock):
    """Falling behind by more than MAX_LAG gives the owed ticks up and counts them.

    After a stall of 0.5 s at 1 kHz, one tick runs, the other 500 owed are given up and
    counted once; the schedule then restarts from that moment.
    """
    assert MAX_LAG < 0.5
    loop, wake, ticks = make_loop()
    clock.now += 1.0 / RATE + 0.5
    wake()
    assert len(ticks) == 1
    assert loop.take_dropped() == 500
    assert loop.take_dropped() == 0
    clock.now += 3.0 / RATE
    wake()
    assert len(ticks) == 4


def test_rate_zero_runs_ticks_on_every_wake_up_and_stands_still_while_paused(clock):
    """Without a wall rate every wake-up runs at least one tick; paused, the timer stops."""
    loop, wake, ticks = make_loop(rate=0.0)
    wake()
    assert len(ticks) >= 1
    loop.set_paused(True)
    assert loop.timer.is_canceled()
    loop.set_paused(False)
    assert not loop.timer.is_canceled()


def test_node_reports_given_up_ticks_on_diagnostics(ros_context, write_scene, clock):
    """Over ROS: a node at 1 kHz whose wall clock jumps 2 s reports WARN and the count.

    The node runs its own loop, which the test kit replaces by its step(): it is made here.
    """
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from rigid_sim.executor import make_executor
    from rigid_sim.node import RigidSimNode
    from ros_tools import record, spin_until
    node = RigidSimNode(context=ros_context, parameter_overrides=[
        Parameter('scene', value=write_scene('bodies:\n  - {name: b, shape: {type: sphere, '
                                             'radius: 0.1}, mass: 1.0}\n')),
        Parameter('rate', value=RATE)])
    probe = Node('probe', context=ros_context)
    heard = record(probe, DiagnosticArray, '/diagnostics')
    executor = make_executor(ros_context)
    executor.add_node(node)
    executor.add_node(probe)
    clock.now += 2.0
    executor.spin_once(timeout_sec=0.1)
    while node.ticks == 0:
        executor.spin_once(timeout_sec=0.1)
    node.publish_diagnostics()
    spin_until(executor, lambda: heard, what='/diagnostics')
    status = heard[-1].status[0]
    values = {item.key: item.value for item in status.values}
    assert int(values['ticks dropped behind wall time']) >= 1900
    assert status.level == DiagnosticStatus.WARN and 'fell behind' in status.message
    executor.shutdown()
    for made in (node, probe):
        made.destroy_node()


def test_rate_changes_switch_between_the_wall_schedule_and_as_fast_as_possible(clock):
    """Rate 50 -> 0 -> 50 at runtime: a zero period, then 20 ms again on a fresh schedule."""
    loop, wake, ticks = make_loop(rate=50.0)
    loop.set_rate(0.0)
    assert loop.timer.timer_period_ns == 0
    wake()
    assert len(ticks) >= 1
    loop.set_rate(50.0)
    assert loop.timer.timer_period_ns == 20_000_000
    before = len(ticks)
    clock.now += 0.02
    wake()
    assert len(ticks) == before + 1


def test_a_rate_change_takes_effect_within_one_period_of_the_new_rate(clock):
    """1 mHz, then 100 Hz: the timer is reset, so its old 1000 s period is not waited out."""
    loop, wake, ticks = make_loop(rate=0.001)
    clock.now += 0.3
    loop.set_rate(100.0)
    assert loop.timer.resets == 1 and loop.timer.timer_period_ns == 10_000_000
    clock.now += 0.01
    wake()
    assert len(ticks) == 1


class SlowTicks:
    """A tick that takes ``cost`` seconds of the (fake) clock that slices are measured on."""

    def __init__(self, clock, cost):
        self.clock, self.cost, self.ticks = clock, cost, []

    def __call__(self, advance, until):
        self.ticks.append(advance)
        self.clock.now += self.cost


@pytest.fixture
def slice_clock(monkeypatch, clock):
    """Let the fake clock drive the slices' perf_counter too."""
    monkeypatch.setattr(tick_loop, 'perf_counter', clock)
    return clock


def test_a_catch_up_returns_to_the_executor_after_one_slice(slice_clock):
    """Owed ticks of 5 ms each: one wake-up runs a slice's worth, the next the rest.

    Between the two, the executor serves control: it never waits for more than one slice
    plus one tick.
    """
    slow = SlowTicks(slice_clock, 0.005)
    loop, wake, _ = make_loop(rate=RATE, tick=slow)
    slice_clock.now += 0.05   # 50 ticks owed, under the lag bound
    wake()
    per_slice = len(slow.ticks)
    assert 1 <= per_slice <= round(tick_loop.SLICE / 0.005) + 1 < 50
    wake()
    assert len(slow.ticks) > per_slice   # the rest of the catch-up follows


def test_a_step_job_runs_in_slices_and_is_answered_when_done(slice_clock):
    """A 100-tick job of 1 ms ticks: slices of SLICE seconds, then one answer with 100."""
    slow = SlowTicks(slice_clock, 0.001)
    node = FakeNode()
    loop = TickLoop(node, slow, rate=0.0)
    loop.set_paused(True)
    answers = []
    loop.run_job(tick_loop.StepJob(100, lambda ran, why: answers.append((ran, why))))
    job_timer = node.timers[1]
    rounds = 0
    while not job_timer.canceled:
        job_timer.callback()
        rounds += 1
    assert answers == [(100, '')] and all(slow.ticks) and len(slow.ticks) == 100
    assert rounds == math.ceil(100 / round(tick_loop.SLICE / 0.001))


def test_pause_ends_a_step_job_after_its_current_tick_saying_how_many_ran(slice_clock):
    """Ending the jobs between two slices answers each with the ticks it ran and why."""
    slow = SlowTicks(slice_clock, 0.001)
    node = FakeNode()
    loop = TickLoop(node, slow, rate=0.0)
    answers = []
    for ticks in (1000, 5):
        loop.run_job(tick_loop.StepJob(ticks, lambda ran, why: answers.append((ran, why))))
    node.timers[1].callback()
    loop.end_jobs('ended by ~/pause')
    ran = len(slow.ticks)
    assert 0 < ran < 1000
    assert answers == [(ran, 'ended by ~/pause'), (0, 'ended by ~/pause')]
    assert node.timers[1].canceled
