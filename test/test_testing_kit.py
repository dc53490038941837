# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The public test kit: the README's example runs, and stepping is deterministic.

A controller that answers each pose with a constant force F acts from the second tick on:
rk4 integrates constant force exactly, so after n ticks of dt the box is at
x0 + F ((n - 1) dt)^2 / 2M, bit for bit the same on two runs.
"""
import math
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, WrenchStamped
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]
DT, MASS, FORCE = 1 / 64, 2.0, 3.0
SCENE = f"""
bodies:
  - {{name: box, shape: {{type: box, size: [0.2, 0.2, 0.2]}}, mass: {MASS}}}
"""


def test_the_readme_controller_example_passes_as_a_users_pytest_file(tmp_path):
    """The README's code block, saved as a user's test file, passes with the plugin alone."""
    readme = (ROOT / 'README.md').read_text()
    section = readme[readme.index('**Testing your controller with pytest.**'):]
    example = re.search(r'```python\n(.*?)```', section, re.S).group(1)
    assert 'def test_' in example and 'rigid_sim' in example
    (tmp_path / 'test_controller.py').write_text(example)
    run = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                          'test_controller.py'], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert '1 passed' in run.stdout


def pushed_run(rigid_sim, ticks):
    """Box pushed by F along x in answer to each pose; the stamps seen (ns), the end state."""
    sim = rigid_sim(yaml=SCENE, time_step=DT, integrator='rk4', wrench_timeout=0.0)
    node = sim.create_node('pusher')
    push = node.create_publisher(WrenchStamped, '/rigid_sim/box/wrench', 10)
    seen = []

    def answer(pose):
        seen.append(pose.header.stamp.sec * 10 ** 9 + pose.header.stamp.nanosec)
        wrench = WrenchStamped()
        wrench.header.frame_id = 'world'
        wrench.wrench.force.x = FORCE
        push.publish(wrench)

    node.create_subscription(PoseStamped, '/rigid_sim/box/pose', answer, 10)
    assert sim.step(ticks) == ticks * DT
    state = sim.state('box')
    sim.close()
    return seen, state


def test_step_lets_callbacks_answer_before_the_next_tick_and_repeats_exactly(rigid_sim):
    ticks = 40
    seen, state = pushed_run(rigid_sim, ticks)
    assert seen == [round(k * DT * 1e9) for k in range(1, ticks + 1)]   # ns, every tick
    pushed_for = (ticks - 1) * DT
    np.testing.assert_allclose(state.position, [FORCE * pushed_for ** 2 / (2 * MASS), 0, 0],
                               rtol=0, atol=1e-13)
    np.testing.assert_allclose(state.velocity, [FORCE * pushed_for / MASS, 0, 0],
                               rtol=0, atol=1e-13)
    again_seen, again = pushed_run(rigid_sim, ticks)
    assert again_seen == seen
    assert again.position.tolist() == state.position.tolist()
    assert again.orientation.tolist() == state.orientation.tolist()


def test_set_pose_from_a_users_node_is_applied_at_the_next_step(rigid_sim):
    """set_pose is subscribed to on demand: the kit connects it before stepping."""
    sim = rigid_sim(yaml=SCENE, time_step=DT)
    node = sim.create_node('placer')
    place = node.create_publisher(PoseStamped, '/rigid_sim/box/set_pose', 10)
    sim.step(1)
    message = PoseStamped()
    message.header.frame_id = 'world'
    message.pose.position.z = 2.5
    place.publish(message)
    sim.step(1)
    np.testing.assert_array_equal(sim.state('box').position, [0.0, 0.0, 2.5])


SPIN = 4.0                             # rad/s about body z, a principal axis of the box
MOUNT = np.array([0.05, -0.02, 0.0])   # m, body frame: the IMU, off the spin axis
SPINNING = f"""
bodies:
  - name: box
    shape: {{type: box, size: [0.2, 0.2, 0.2]}}
    mass: {MASS}
    pose: {{position: [1.0, 2.0, 3.0]}}
    twist: {{linear: [0.5, 0.0, 0.0], angular: [0.0, 0.0, {SPIN}]}}
    imu: {{point: {MOUNT.tolist()}}}
"""


def test_reset_pause_and_resume_act_as_the_services_do(rigid_sim):
    """Paused, steps publish at a standing time; reset goes back to t = 0 and the scene's state.

    The box flies freely: x = x0 + v t (rk4 is exact here).
    """
    sim = rigid_sim(yaml=SPINNING, time_step=DT, integrator='rk4')
    node = sim.create_node('watcher')
    poses = []
    node.create_subscription(PoseStamped, sim.topic('box/pose'), poses.append, 10)
    sim.step(4)
    sim.pause()
    sim.step(3)
    assert sim.time == 4 * DT and len(poses) == 7
    assert {pose.header.stamp.nanosec for pose in poses[4:]} == {round(4 * DT * 1e9)}
    sim.resume()
    sim.step(2)
    assert sim.time == 6 * DT
    np.testing.assert_allclose(sim.state('box').position, [1.0 + 0.5 * 6 * DT, 2.0, 3.0],
                               rtol=0, atol=1e-14)
    sim.reset()
    with pytest.raises(LookupError, match='step first'):
        sim.imu('box')   # the readings before the reset are gone
    assert sim.time == 0.0
    np.testing.assert_array_equal(sim.state('box').position, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(sim.state('box').angular_velocity, [0.0, 0.0, SPIN])


def test_set_state_applies_at_once_and_the_body_flies_on_from_it(rigid_sim):
    """A pose and twist set by the kit show at once; free flight goes on from them exactly."""
    sim = rigid_sim(yaml=SPINNING, time_step=DT, integrator='rk4')
    sim.step(2)
    turn = Rotation.from_rotvec([0.3, -0.2, 0.1])
    sim.set_state('box', pose=([0.0, 1.0, -1.0], turn.as_quat()),
                  twist=([0.0, -2.0, 1.0], [0.0, 0.0, 0.0]))
    now = sim.state('box')
    assert now.time == 2 * DT
    np.testing.assert_array_equal(now.position, [0.0, 1.0, -1.0])
    np.testing.assert_allclose(now.orientation, turn.as_quat(), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(now.velocity, [0.0, -2.0, 1.0])
    sim.step(8)
    np.testing.assert_allclose(sim.state('box').position, [0.0, 1.0 - 2.0 * 8 * DT,
                                                           -1.0 + 8 * DT], rtol=0, atol=1e-14)
    before = sim.state('box')
    with pytest.raises(ValueError, match='unit'):
        sim.set_state('box', pose=([0.0, 0.0, 0.0], [0.0, 0.0, 0.5, 0.5]))
    with pytest.raises(ValueError, match='non-finite'):
        sim.set_state('box', twist=([0.0, math.nan, 0.0], [0.0, 0.0, 0.0]))
    assert sim.state('box').position.tolist() == before.position.tolist()
    assert sim.state('box').velocity.tolist() == before.velocity.tolist()


def test_imu_gives_the_latest_reading_of_a_spinning_body(rigid_sim):
    """A spin omega about a principal axis: gyro (0, 0, omega), f = -omega^2 (rx, ry, 0)."""
    sim = rigid_sim(yaml=SPINNING, time_step=DT)
    with pytest.raises(LookupError, match='no IMU publishes'):
        sim.imu('box')
    sim.step(5)
    reading = sim.imu('box')
    assert reading.time == sim.time == 5 * DT and reading.frame_id == 'box/imu'
    np.testing.assert_allclose(reading.angular_velocity, [0.0, 0.0, SPIN], rtol=0, atol=1e-12)
    np.testing.assert_allclose(reading.linear_acceleration,
                               -SPIN ** 2 * np.array([MOUNT[0], MOUNT[1], 0.0]), atol=1e-12)
    np.testing.assert_allclose(reading.orientation,
                               Rotation.from_rotvec([0.0, 0.0, SPIN * 5 * DT]).as_quat(),
                               atol=1e-12)
    assert reading.magnetic_field is None
    with pytest.raises(LookupError, match='no IMU publishes on /rigid_sim/box/other'):
        sim.imu('box', 'other')


def test_properties_give_mass_inertia_and_centre_of_mass(rigid_sim):
    """A box of density rho: M = rho a b c, I = M diag(b^2 + c^2, ...) / 12 about its centre.

    A sphere given a mass has I = 2 M r^2 / 5; both centres of mass are their origins.
    """
    sides, rho = np.array([0.4, 0.2, 0.1]), 500.0
    sim = rigid_sim(yaml=f"""
bodies:
  - {{name: brick, shape: {{type: box, size: {sides.tolist()}}}, density: {rho}}}
  - {{name: ball, shape: {{type: sphere, radius: 0.5}}, mass: 3.0}}
""")
    brick = sim.properties('brick')
    mass = rho * np.prod(sides)
    assert brick.mass == pytest.approx(mass, rel=1e-15)
    squares = sides ** 2
    np.testing.assert_allclose(brick.inertia, mass / 12 * np.diag(
        [squares[1] + squares[2], squares[0] + squares[2], squares[0] + squares[1]]),
        rtol=1e-14, atol=1e-17)
    np.testing.assert_array_equal(brick.center_of_mass, [0.0, 0.0, 0.0])
    ball = sim.properties('ball')
    assert ball.mass == 3.0
    np.testing.assert_allclose(ball.inertia, np.eye(3) * 0.4 * 3.0 * 0.25, rtol=1e-14)
    with pytest.raises(KeyError, match="unknown body 'nothing'"):
        sim.properties('nothing')


def test_two_simulators_in_one_test_each_in_its_namespace(rigid_sim):
    """Each has its own topics: a push on one moves its box only. One name twice is refused."""
    first = rigid_sim(yaml=SCENE, namespace='one', time_step=DT, integrator='rk4')
    second = rigid_sim(yaml=SCENE, namespace='two', time_step=DT, integrator='rk4')
    assert first.topic('box/wrench') == '/one/rigid_sim/box/wrench'
    node = first.create_node('pusher')
    push = node.create_publisher(WrenchStamped, second.topic('box/wrench'), 10)
    second.connect()   # published before its subscription matches, a message is lost
    wrench = WrenchStamped()
    wrench.header.frame_id = 'world'
    wrench.wrench.force.x = FORCE
    push.publish(wrench)
    second.step(4)
    np.testing.assert_allclose(second.state('box').position[0],
                               FORCE * (4 * DT) ** 2 / (2 * MASS), rtol=0, atol=1e-14)
    assert first.state('box').position.tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match='already runs.*namespace='):
        rigid_sim(yaml=SCENE, namespace='one')


def test_step_stops_at_its_wall_clock_timeout_naming_the_step(rigid_sim):
    """A timeout already passed stops before any tick; a slow callback stops the run early.

    The callback sleeps 0.05 s per pose, so 100 ticks take at least 5 s: a 0.3 s timeout
    ends them well before.
    """
    sim = rigid_sim(yaml=SCENE, time_step=DT)
    with pytest.raises(TimeoutError, match=r'step\(5\) .*timeout of 0 s .* after 0 of 5 ticks'):
        sim.step(5, timeout=0.0)
    assert sim.time == 0.0
    node = sim.create_node('slow')
    node.create_subscription(PoseStamped, sim.topic('box/pose'), lambda _: time.sleep(0.05),
                             10)
    with pytest.raises(TimeoutError, match=r'step\(100\) .*timeout of 0.3 s'):
        sim.step(100, timeout=0.3)
    assert 0 < sim.time < 100 * DT


def test_the_log_line_says_no_wall_clock_runs(rigid_sim, capfd):
    rigid_sim(yaml=SCENE, time_step=DT)
    line, = [line for line in capfd.readouterr().err.splitlines() if 'simulating' in line]
    assert 'no wall clock' in line and 'step()' in line
    assert 'Hz' not in line and 'real-time factor' not in line
