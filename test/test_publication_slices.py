# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A publication to many per-body topics goes out in slices, control answered between.

A tick whose publication meets its deadline stops after BODIES_A_CHECK bodies and the next
call goes on from the same snapshot; listeners are counted BODIES_A_LOOK bodies a look. The
bodies stand still at x = i, so every pose says which body it is and when it was taken.
"""
from geometry_msgs.msg import PoseStamped

from rigid_sim import outputs
from rigid_sim.conversions import to_seconds
from rigid_sim.testing import run_ready_callbacks
from rigid_sim.testing.delivery import deliver, wait_until

BODIES = 70
SCENE = 'bodies:\n' + '\n'.join(
    f'  - {{name: b{i}, shape: {{type: sphere, radius: 0.1}}, mass: 1.0, '
    f'pose: {{position: [{i}.0, 0.0, 0.0]}}}}' for i in range(BODIES))
TIME_STEP = 0.01


def _hear_every_pose(sim):
    """Subscribe to every body's pose; the list of (body, x, stamp s) received."""
    received, hearer = [], sim.create_node('hearer')
    for index in range(BODIES):
        hearer.create_subscription(
            PoseStamped, sim.topic(f'b{index}/pose'),
            lambda message, i=index: received.append(
                (i, message.pose.position.x, to_seconds(message.header.stamp))), 100)
    publishers = [p for p in sim.node.publishers if p.topic_name.endswith('/pose')]
    assert wait_until(sim.executor, lambda: all(p.get_subscription_count() for p in publishers),
                      10.0)
    sim.node.outputs.refresh_listeners()
    return received


def _slices_of_one_tick(sim):
    """Run one tick with its deadline already past in every call; how many calls it took."""
    calls = 1
    while not sim.node._tick(True, until=0.0):
        calls += 1
    return calls


def test_a_publication_past_its_deadline_goes_on_from_the_same_snapshot(rigid_sim):
    sim = rigid_sim(yaml=SCENE, time_step=TIME_STEP, rate=0.0)
    received = _hear_every_pose(sim)
    ticks = sim.node.ticks
    assert not sim.node._tick(True, until=0.0)
    deliver(sim.executor)
    assert len(received) == outputs.BODIES_A_CHECK   # one share, then the deadline
    calls = 1 + _slices_of_one_tick(sim)
    deliver(sim.executor)
    assert calls == -(-BODIES // outputs.BODIES_A_CHECK)
    assert sim.node.ticks == ticks + 1 and sim.time == TIME_STEP   # one tick's steps
    assert sorted(index for index, _, _ in received) == list(range(BODIES))
    assert all(x == index and stamp == TIME_STEP for index, x, stamp in received)


def test_without_a_deadline_a_publication_goes_out_in_one_call(rigid_sim):
    sim = rigid_sim(yaml=SCENE, time_step=TIME_STEP, rate=0.0)
    received = _hear_every_pose(sim)
    assert sim.node._tick(True, until=None)
    deliver(sim.executor)
    assert sorted(index for index, _, _ in received) == list(range(BODIES))


def test_listeners_are_counted_a_share_of_the_bodies_a_look(rigid_sim, monkeypatch):
    monkeypatch.setattr(outputs, 'BODIES_A_LOOK', 30)
    sim = rigid_sim(yaml=SCENE, time_step=TIME_STEP, rate=0.0)
    received = _hear_every_pose(sim)
    heard = []
    for _ in range(3):   # 30 + 30 + 10 bodies looked at
        sim.node.outputs.refresh_listeners()
        sim.node._tick(True, until=None)
        run_ready_callbacks(sim.executor)
        deliver(sim.executor)
        heard.append(sorted({index for index, _, _ in received}))
        received.clear()
    assert heard == [list(range(30)), list(range(60)), list(range(BODIES))]
