# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The ``rigid_sim_node`` executable as its own process, talking over DDS.

The environment comes from conftest.py (this run's ROS_DOMAIN_ID, discovery on localhost);
each node process also gets a namespace of its own. Waits are on received messages and
matched endpoints with generous timeouts, never on sleeps.
"""
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseArray, PoseStamped, WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from std_srvs.srv import SetBool, Trigger

from physics_cases import FLIGHT_STEP as STEP, FLIGHT_V0 as V0, FLIGHT_X0 as X0
from physics_cases import FLYING_BOX
import processes
from rigid_sim import conversions
from ros_tools import TIMEOUT, record, spin_until

EXECUTABLE = Path(sys.executable).with_name('rigid_sim_node')
NAMESPACE = f'/t{os.getpid()}'
START_TIMEOUT = 600.0  # s: imports, a cold compile, discovery, on a loaded 2-core machine


def start_node(*ros_arguments, cwd):
    """Start the installed console script with ``--ros-args`` in this run's namespace."""
    assert EXECUTABLE.is_file(), f'{EXECUTABLE} missing: pip install -e . first'
    return processes.start([str(EXECUTABLE), '--ros-args', '-r', f'__ns:={NAMESPACE}',
                            *ros_arguments], cwd=cwd, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)


@pytest.fixture
def probe():
    """Yield a node in this test process, on this run's domain, with its executor."""
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node('probe', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    yield node, executor
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def test_node_process_publishes_poses_and_moves_under_a_wrench(probe, tmp_path):
    """The packaged wrenches scene, found by bare name, runs.

    A 10 N world force along x from another process accelerates the cart along x only (no gravity
    in that scene).
    """
    node, executor = probe
    process = start_node('-p', 'scene:=wrenches.yaml', cwd=tmp_path)
    try:
        poses = []
        node.create_subscription(PoseStamped, f'{NAMESPACE}/rigid_sim/cart/pose',
                                 poses.append, 10)
        spin_until(executor, lambda: poses, START_TIMEOUT, 'first cart pose')
        start = poses[-1].pose.position
        push = node.create_publisher(WrenchStamped, f'{NAMESPACE}/rigid_sim/cart/wrench', 10)
        spin_until(executor, lambda: push.get_subscription_count() >= 1, TIMEOUT,
                   'wrench topic matched')
        message = WrenchStamped()
        message.header.frame_id = 'world'
        message.wrench.force.x = 10.0
        push.publish(message)
        spin_until(executor, lambda: poses[-1].pose.position.x > start.x + 0.05, TIMEOUT,
                   'cart moved along x')
        moved = poses[-1].pose.position
        assert (moved.y, moved.z) == (start.y, start.z)
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=TIMEOUT) == 0
    finally:
        processes.end(process)
        output = process.communicate()[0]
    assert 'simulating 3 bodies' in output and 'wrenches.yaml' in output


def write_misspelt_parameters(tmp_path):
    path = tmp_path / 'params.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': {'time_stepp': 0.01}}}))
    return ['--params-file', str(path)]


def write_malformed_scene(tmp_path):
    path = tmp_path / 'bad_scene.yaml'
    path.write_text('bodies:\n  - name: box\n    shape: {type: box, size: [1.0, 1.0]}\n'
                    '    mass: 1.0\n')
    return ['-p', f'scene:={path}']


@pytest.mark.parametrize('arguments, expected', [
    (lambda tmp: ['-p', 'rate:=-3'], ["parameter 'rate'", '-3', 'outside the range']),
    (lambda tmp: ['-p', 'integrator:=leapfrog'], ['unknown integrator', 'rk4']),
    (write_misspelt_parameters, ["unknown parameter(s) ['time_stepp']"]),
    (write_malformed_scene, ['bad_scene.yaml', 'bodies[0].shape.size', 'list of 3 numbers']),
    (lambda tmp: ['-p', 'scene:=nowhere.yaml'], ["'nowhere.yaml' not found"]),
])
def test_refused_start_names_the_reason_and_exits_nonzero(tmp_path, arguments, expected):
    """A bad parameter or scene stops the process at once with status 1 and says why."""
    process = start_node(*arguments(tmp_path), cwd=tmp_path)
    output = process.communicate(timeout=START_TIMEOUT)[0]
    assert process.returncode == 1, output
    assert 'refused to start' in output
    for words in expected:
        assert words in output


def run_lockstep(node, executor, cwd, calls, step_ticks=5):
    """Start the default scene paused at rate 0 and drive it by ~/step only.

    Returns, per call, the time it answered and every body's pose (position and
    orientation) from the PoseArray stamped with that time.
    """
    process = start_node('-p', 'rate:=0', '-p', 'start_paused:=true',
                         '-p', f'step_ticks:={step_ticks}', cwd=cwd)
    poses = []
    subscription = node.create_subscription(PoseArray, f'{NAMESPACE}/rigid_sim/poses',
                                            poses.append, 100)
    client = node.create_client(Trigger, f'{NAMESPACE}/rigid_sim/step')
    try:
        spin_until(executor, client.service_is_ready, START_TIMEOUT, '~/step ready')
        spin_until(executor, lambda: subscription.get_publisher_count() >= 1, TIMEOUT,
                   '~/poses matched')
        results = []
        for _ in range(calls):
            future = client.call_async(Trigger.Request())
            spin_until(executor, future.done, TIMEOUT, '~/step answered')
            answer = future.result()
            assert answer.success, answer.message
            time = float(answer.message.split()[4])
            stamp = conversions.to_time(time)
            spin_until(executor, lambda: poses and poses[-1].header.stamp == stamp, TIMEOUT,
                       f'poses at {time} s')
            results.append((time, [(p.position.x, p.position.y, p.position.z, p.orientation.x,
                                    p.orientation.y, p.orientation.z, p.orientation.w)
                                   for p in poses[-1].poses]))
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=TIMEOUT) == 0
    finally:
        processes.end(process)
        process.communicate()
        node.destroy_subscription(subscription)
        node.destroy_client(client)
    return results


def test_lockstep_from_another_process_gives_bit_identical_poses(probe, tmp_path):
    """Two runs of the default scene driven by ~/step alone give bit-identical poses.

    Both run at rate 0, started paused: the same times, k x 5 ticks x 0.01 s, and bit for
    bit the same poses after every call.
    """
    node, executor = probe
    first = run_lockstep(node, executor, tmp_path, calls=8)
    second = run_lockstep(node, executor, tmp_path, calls=8)
    expected_times = [0.05 * (k + 1) for k in range(8)]
    assert [t for t, _ in first] == pytest.approx(expected_times, rel=1e-12)
    assert first == second
    assert first[0][1] != first[-1][1]  # the bodies moved: the comparison means something


def call(node, executor, service_type, name, request):
    """Call ``name`` of the node process from ``node``; the response."""
    client = node.create_client(service_type, f'{NAMESPACE}/rigid_sim/{name}')
    spin_until(executor, client.service_is_ready, TIMEOUT, f'~/{name} ready')
    future = client.call_async(request)
    spin_until(executor, future.done, TIMEOUT, f'~/{name} answered')
    node.destroy_client(client)
    return future.result()


def test_rate_zero_ticks_without_a_wall_clock_and_stands_still_while_paused(probe, tmp_path):
    """At rate 0 the node ticks as fast as it can; paused, it ticks only on ~/step.

    This is the node's own loop, which the test kit replaces, so it runs as a process. /clock
    advances by exactly time_step per tick: a subscriber slower than the node may miss some
    /clock messages (the publisher keeps the last 10), so the received times are checked to
    be whole, increasing tick counts, and each pose to be x0 + v0 t at its stamp. Paused, the
    clock stands at the time of the last tick until ~/step advances it by one.
    /diagnostics, with no wall rate to aim at, states no real-time factor target and is OK.
    """
    node, executor = probe
    scene = tmp_path / 'flying_box.yaml'
    scene.write_text(FLYING_BOX)
    clock = record(node, Clock, '/clock')
    poses = record(node, PoseStamped, f'{NAMESPACE}/rigid_sim/box/pose')
    diagnostics = record(node, DiagnosticArray, '/diagnostics')
    process = start_node('-p', f'scene:={scene}', '-p', 'rate:=0', '-p', f'time_step:={STEP}',
                         cwd=tmp_path)

    def latest_time():
        return conversions.to_seconds(clock[-1].clock)
    try:
        spin_until(executor, lambda: clock and latest_time() >= 2.0 and len(poses) >= 5,
                   START_TIMEOUT, 'two simulated seconds and five poses')
        ticks = np.array([conversions.to_seconds(m.clock) for m in clock]) / STEP
        np.testing.assert_array_equal(ticks, np.round(ticks))
        assert np.all(np.diff(ticks) > 0)
        for pose in poses[-5:]:
            np.testing.assert_allclose(conversions.pose_arrays(pose.pose)[0],
                                       X0 + V0 * conversions.to_seconds(pose.header.stamp),
                                       rtol=0, atol=1e-12)
        assert call(node, executor, SetBool, 'pause', SetBool.Request(data=True)).success
        answer = call(node, executor, Trigger, 'step', Trigger.Request())
        assert answer.success
        stepped = float(answer.message.split()[-2])   # 'advanced 1 ticks to T s', exact
        spin_until(executor, lambda: latest_time() == stepped, TIMEOUT, 'the stepped tick')
        assert conversions.to_seconds(clock[-2].clock) == stepped - STEP   # it stood still
        for _ in range(20):
            executor.spin_once(timeout_sec=0.01)
        assert latest_time() == stepped
        spin_until(executor, lambda: poses[-1].header.stamp == conversions.to_time(stepped),
                   TIMEOUT, 'the stepped pose')
        np.testing.assert_allclose(conversions.pose_arrays(poses[-1].pose)[0],
                                   X0 + V0 * stepped, rtol=0, atol=1e-12)
        spin_until(executor, lambda: diagnostics, TIMEOUT, '/diagnostics')
        status = diagnostics[-1].status[0]
        values = conversions.diagnostic_values(diagnostics[-1])
        assert values['real-time factor target'].startswith('none')
        assert status.level == DiagnosticStatus.OK
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=TIMEOUT) == 0
    finally:
        processes.end(process)
        process.communicate()
