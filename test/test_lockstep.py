# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Lockstep over ROS: start paused, advance by ~/step, and rate 0 (as fast as possible).

One box in free flight, x = x0 + v0 t, stepped by 1/64 s (exact in binary, so simulated
times add up exactly and every expected value below is exact).
"""
import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from std_srvs.srv import SetBool, Trigger

from rigid_sim import conversions
from ros_harness import spin_until

STEP = 1 / 64  # s
X0, V0 = np.array([1.0, -2.0, 0.5]), np.array([0.5, 0.25, -1.0])
SCENE = f"""
bodies:
  - name: box
    shape: {{type: box, size: [0.4, 0.2, 0.1]}}
    mass: 2.0
    pose: {{position: {X0.tolist()}}}
    twist: {{linear: {V0.tolist()}}}
"""


def stamps(sim, topic):
    return [conversions.to_seconds(m.header.stamp if hasattr(m, 'header') else m.clock)
            for m in sim.received[topic]]


def test_started_paused_the_node_advances_only_by_step_and_publishes_every_tick(
        harness, write_scene):
    """Started paused, the node holds t = 0 and advances only by ~/step.

    Each ~/step advances step_ticks ticks, publishes each of them (stamps STEP, 2 STEP,
    3 STEP) and answers with the new time once they are done.
    """
    sim = harness(write_scene(SCENE), time_step=STEP, start_paused=True, step_ticks=3)
    sim.tick(2)   # ticks of the wall-clock loop while paused: time stands at 0
    assert stamps(sim, sim.topic('box/pose')) == [0.0, 0.0]
    answer = sim.call(Trigger, 'step', Trigger.Request())
    assert answer.success
    assert answer.message.endswith(f'{3 * STEP!r} s')
    spin_until(sim.executor, lambda: len(sim.received[sim.topic('box/pose')]) == 5,
               what='the poses of the three ticks')
    assert stamps(sim, sim.topic('box/pose'))[2:] == [STEP, 2 * STEP, 3 * STEP]
    assert stamps(sim, '/clock')[-3:] == [STEP, 2 * STEP, 3 * STEP]
    position, _, velocity, _, t = sim.state('box')
    np.testing.assert_array_equal(velocity, V0)
    np.testing.assert_allclose(position, X0 + V0 * t, rtol=0, atol=1e-15)
    assert sim.call(Trigger, 'step', Trigger.Request()).message.endswith(f'{6 * STEP!r} s')


def test_step_is_refused_with_the_reason_while_running(harness, write_scene):
    """~/step while running: success false, the reason, and no tick run."""
    sim = harness(write_scene(SCENE), time_step=STEP)
    sim.tick(1)
    answer = sim.call(Trigger, 'step', Trigger.Request())
    assert not answer.success
    assert 'only while paused' in answer.message
    assert sim.sim.world.time == STEP
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    assert sim.call(Trigger, 'step', Trigger.Request()).success
    assert sim.sim.world.time == 2 * STEP


def test_rate_zero_ticks_without_a_wall_clock_and_stands_still_while_paused(
        harness, write_scene):
    """At rate 0 the node ticks as fast as it can; paused, it ticks only on ~/step.

    /clock advances by exactly time_step per tick. A subscriber slower than the node may
    miss some /clock messages (the publisher keeps the last 10), so the received times are
    checked to be whole, increasing tick counts. /diagnostics, with no wall rate to aim at,
    states no real-time factor target and stays OK.
    """
    sim = harness(write_scene(SCENE), ticking=True, rate=0, time_step=STEP)
    clock = sim.received['/clock']
    spin_until(sim.executor, lambda: clock and conversions.to_seconds(clock[-1].clock) >= 2.0,
               what='two simulated seconds')
    ticks = np.array(stamps(sim, '/clock')) / STEP
    np.testing.assert_array_equal(ticks, np.round(ticks))
    assert np.all(np.diff(ticks) > 0)
    assert sim.sim.world.time == sim.sim.ticks * STEP
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    paused_at = sim.sim.world.time

    def latest_time():
        return conversions.to_seconds(clock[-1].clock)
    spin_until(sim.executor, lambda: latest_time() == paused_at, what='the last tick')
    for _ in range(20):
        sim.executor.spin_once(timeout_sec=0.01)
    assert latest_time() == paused_at == sim.sim.world.time
    assert sim.call(Trigger, 'step', Trigger.Request()).success
    spin_until(sim.executor, lambda: latest_time() == paused_at + STEP, what='the stepped tick')
    pose = sim.latest('box/pose')
    np.testing.assert_allclose(conversions.pose_arrays(pose.pose)[0],
                               X0 + V0 * (paused_at + STEP), rtol=0, atol=1e-12)
    values = sim.diagnostics()   # no wall rate: no real-time factor to aim at, no WARN
    assert values['real-time factor target'].startswith('none')
    assert sim.latest('/diagnostics').status[0].level == DiagnosticStatus.OK
