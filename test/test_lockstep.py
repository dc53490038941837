# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Lockstep over ROS: start paused and advance by ~/step (rate 0: test_process.py).

One box in free flight, x = x0 + v0 t, stepped by 1/64 s (exact in binary, so simulated
times add up exactly and every expected value below is exact).
"""
import numpy as np
from std_srvs.srv import SetBool, Trigger

import ros_tools
from physics_cases import FLIGHT_STEP as STEP, FLIGHT_V0 as V0, FLIGHT_X0 as X0
from physics_cases import FLYING_BOX as SCENE


def test_started_paused_the_node_advances_only_by_step_and_publishes_every_tick(rigid_sim):
    """Started paused, the node holds t = 0 and advances only by ~/step.

    Each ~/step advances step_ticks ticks, publishes each of them (stamps STEP, 2 STEP,
    3 STEP) and answers with the new time once they are done.
    """
    sim = rigid_sim(yaml=SCENE, time_step=STEP, start_paused=True, step_ticks=3)
    probe = ros_tools.Probe(sim, 'box')
    sim.step(2)   # ticks of the wall-clock loop while paused: time stands at 0
    assert probe.stamps('box/pose') == [0.0, 0.0]
    answer = sim.call(Trigger, 'step', Trigger.Request())
    assert answer.success
    assert answer.message.endswith(f'{3 * STEP!r} s')
    assert probe.stamps('box/pose')[2:] == [STEP, 2 * STEP, 3 * STEP]   # all delivered
    assert probe.stamps('/clock')[-3:] == [STEP, 2 * STEP, 3 * STEP]
    position, _, velocity, _, t = probe.state('box')
    np.testing.assert_array_equal(velocity, V0)
    np.testing.assert_allclose(position, X0 + V0 * t, rtol=0, atol=1e-15)
    assert sim.call(Trigger, 'step', Trigger.Request()).message.endswith(f'{6 * STEP!r} s')


def test_step_is_refused_with_the_reason_while_running(rigid_sim):
    """~/step while running: success false, the reason, and no tick run."""
    sim = rigid_sim(yaml=SCENE, time_step=STEP)
    sim.step(1)
    answer = sim.call(Trigger, 'step', Trigger.Request())
    assert not answer.success
    assert 'only while paused' in answer.message
    assert sim.time == STEP
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    assert sim.call(Trigger, 'step', Trigger.Request()).success
    assert sim.time == 2 * STEP
