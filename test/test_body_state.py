# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Setting a body's pose and twist at runtime: in the core, then over ROS.

Expected values come from the body-frame pose and twist that were set, read back through
the world's own kinematics (Snapshot), and from free motion after the change: a sphere
moves at constant velocity and turns at constant angular velocity, x = p + v t,
R(t) = exp([omega] t) R0.
"""
import math
from pathlib import Path

import numpy as np
import yaml
import pytest
from scipy.spatial.transform import Rotation
from std_srvs.srv import SetBool

import ros_tools
from rigid_sim.core.body_state import UNIT_QUATERNION_TOLERANCE, with_pose, with_twist
from rigid_sim.core.scene import build_world, parse_scene

STEP = 1 / 64  # s
L_BLOCK = Path(__file__).resolve().parents[1] / 'config' / 'meshes' / 'l_block.obj'
# The L block's centre of mass is off its frame origin, so pose and twist of the frame
# differ from those of the centre of mass.
MESH_FREE = f"""
bodies:
  - name: offset
    shape: {{type: mesh, file: {L_BLOCK}}}
    mass: 3.0
    pose: {{position: [0.3, -0.2, 1.0], orientation: [0.1, 0.2, -0.3, 0.927]}}
    twist: {{linear: [0.1, 0.0, -0.2], angular: [0.5, 1.0, 2.0]}}
  - name: ball
    shape: {{type: sphere, radius: 0.1}}
    mass: 1.0
    pose: {{position: [0.0, 1.0, 0.0]}}
    twist: {{linear: [0.0, 0.5, 0.0], angular: [0.0, 0.0, 3.0]}}
"""
POSE = (np.array([-1.0, 2.0, 0.5]), Rotation.from_rotvec([0.3, -0.6, 0.9]).as_quat())
TWIST = (np.array([0.25, -0.5, 1.0]), np.array([-2.0, 0.5, 1.5]))


@pytest.fixture
def world():
    made = build_world(parse_scene(yaml.safe_load(MESH_FREE)), 'rk4')
    assert np.linalg.norm(made.bodies.com_in_body[0]) > 0.05  # the premise
    return made


def frame_state(world, index):
    snapshot = world.snapshot()
    origin, orientation = snapshot.body_frame_pose()
    velocity, angular_velocity = snapshot.body_frame_twist()
    return origin[index], orientation[index], velocity[index], angular_velocity[index]


def test_set_pose_places_the_frame_keeps_its_twist_and_no_other_row(world):
    """After with_pose the world reads back the pose set and the twist it had before.

    The other body's row and the given array are bitwise unchanged.
    """
    before = world.y.copy()
    _, _, velocity, angular_velocity = frame_state(world, 0)
    world.y = with_pose(world.bodies, world.y, 0, *POSE)
    origin, orientation, new_velocity, new_angular_velocity = frame_state(world, 0)
    np.testing.assert_allclose(origin, POSE[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(orientation, POSE[1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(new_velocity, velocity, rtol=0, atol=1e-14)
    np.testing.assert_allclose(new_angular_velocity, angular_velocity, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(world.y[1], before[1])
    assert world.y is not before


def test_set_twist_moves_the_frame_origin_as_given_and_keeps_the_pose(world):
    """The velocity with_twist sets is the frame origin's, not the centre of mass's.

    The centre of mass then moves at v + omega x R c, and the momentum is M times that.
    """
    origin, orientation, _, _ = frame_state(world, 0)
    world.y = with_twist(world.bodies, world.y, 0, *TWIST)
    new_origin, new_orientation, velocity, angular_velocity = frame_state(world, 0)
    np.testing.assert_array_equal(new_orientation, orientation)
    np.testing.assert_allclose(new_origin, origin, rtol=0, atol=1e-15)
    np.testing.assert_allclose(velocity, TWIST[0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(angular_velocity, TWIST[1], rtol=0, atol=1e-14)
    offset = Rotation.from_quat(orientation).apply(world.bodies.com_in_body[0])
    np.testing.assert_allclose(world.y[0, 7:10] / 3.0, TWIST[0] + np.cross(TWIST[1], offset),
                               rtol=0, atol=1e-14)


@pytest.mark.parametrize('change, reason', [
    (lambda w: with_pose(w.bodies, w.y, 0, [math.nan, 0, 0], [0, 0, 0, 1]), 'non-finite'),
    (lambda w: with_pose(w.bodies, w.y, 0, [0, 0, 0], [0, 0, 0, 1.1]), 'not a unit'),
    (lambda w: with_pose(w.bodies, w.y, 0, [0, 0, 0], [0, 0, 0, 0]), 'not a unit'),
    (lambda w: with_twist(w.bodies, w.y, 0, [0, 0, 0], [0, math.inf, 0]), 'non-finite'),
    # 1e308 m/s would overflow P = M v to inf, 1e200 rad/s the energy I w^2.
    (lambda w: with_twist(w.bodies, w.y, 0, [1e308, 0, 0], [0, 0, 0]),
     r'linear\.x is 1e\+308, above 1e\+15'),
    (lambda w: with_twist(w.bodies, w.y, 0, [0, 0, 0], [1e200, 0, 0]), r'angular\.x is 1e\+200'),
    (lambda w: with_pose(w.bodies, w.y, 0, [0, 0, -1e16], [0, 0, 0, 1]), r'position\.z is'),
    (lambda w: with_pose(w.bodies, w.y, 0, [0, 5e-324, 0], [0, 0, 0, 1]),
     r'position\.y is 4\.94e-324, a subnormal number: write floats \(15\.0\)'),
    (lambda w: with_pose(w.bodies, w.y, 0, [0, 0, 0], [1e-310, 0, 0, 1]),
     r'orientation\.x .* subnormal'),
])
def test_bad_state_is_refused_and_changes_nothing(world, change, reason):
    before = world.y.copy()
    with pytest.raises(ValueError, match=reason):
        change(world)
    np.testing.assert_array_equal(world.y, before)


def test_a_twist_at_the_scene_number_bound_is_taken_and_stays_finite(world):
    """1e15 m/s and rad/s, the largest a scene may give, set finite momenta and energy.

    P = M (v + omega x R c) and L = I omega are read back through the state: the frame
    origin moves at the velocity set, to double precision.
    """
    bound = np.full(3, 1e15)
    world.y = with_twist(world.bodies, world.y, 0, bound, -bound)
    assert np.all(np.isfinite(world.y)) and math.isfinite(world.energy())
    _, _, velocity, angular_velocity = frame_state(world, 0)
    np.testing.assert_allclose(angular_velocity, -bound, rtol=1e-12)
    np.testing.assert_allclose(velocity, bound, rtol=1e-9)


def test_nearly_unit_quaternion_is_normalised(world):
    """|q|^2 within the tolerance of 1: accepted as the rotation it stands for."""
    q = np.array([0.0, 0.0, 0.0, math.sqrt(1.0 + 0.9 * UNIT_QUATERNION_TOLERANCE)])
    world.y = with_pose(world.bodies, world.y, 0, [0.0, 0.0, 0.0], q)
    np.testing.assert_array_equal(world.y[0, 3:7], [0.0, 0.0, 0.0, 1.0])


@pytest.fixture
def paused(rigid_sim):
    """Run the scene over ROS, paused after two ticks (paused ticks apply inputs and publish).

    As (simulation, probe).
    """
    sim = rigid_sim(yaml=MESH_FREE, time_step=STEP, integrator='rk4')
    probe = ros_tools.Probe(sim, 'offset', 'ball')
    sim.step(2)
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    return sim, probe


def test_set_pose_and_twist_over_ros_take_effect_at_the_next_tick(paused):
    """A pose and twist set over ROS are published after the next tick, time untouched.

    Resumed, the ball (a sphere) flies on from them: p + v t, exp([omega] t) R.
    """
    sim, probe = paused
    ball_before = probe.state('ball')
    probe.send('offset', 'set_pose', ros_tools.pose(*POSE))
    probe.send('ball', 'set_twist', ros_tools.twist(*TWIST))
    probe.send('ball', 'set_pose', ros_tools.pose(*POSE))
    sim.step(1)
    position, orientation, velocity, angular_velocity, t = probe.state('offset')
    assert t == 2 * STEP
    np.testing.assert_allclose(position, POSE[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(orientation, POSE[1], rtol=0, atol=1e-15)
    position, orientation, velocity, angular_velocity, _ = probe.state('ball')
    np.testing.assert_allclose(velocity, TWIST[0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(angular_velocity, TWIST[1], rtol=0, atol=1e-14)
    assert ball_before[0].tolist() != position.tolist()
    assert sim.call(SetBool, 'pause', SetBool.Request(data=False)).success
    sim.step(8)
    position, orientation, _, _, t = probe.state('ball')
    assert t == 10 * STEP
    np.testing.assert_allclose(position, POSE[0] + TWIST[0] * 8 * STEP, rtol=0, atol=1e-12)
    turned = Rotation.from_rotvec(TWIST[1] * 8 * STEP) * Rotation.from_quat(POSE[1])
    assert (Rotation.from_quat(orientation) * turned.inv()).magnitude() < 1e-9


@pytest.mark.parametrize('body, topic, message, reason', [
    ('offset', 'set_pose', ros_tools.pose([math.nan, 0, 0], [0, 0, 0, 1]), 'non-finite'),
    ('offset', 'set_pose', ros_tools.pose([0, 0, 0], [0, 0, 0.5, 0.5]), 'not a unit'),
    ('offset', 'set_pose', ros_tools.pose([0, 0, 0], [0, 0, 0, 1], frame_id='offset'),
     'unknown frame_id'),
    ('offset', 'set_twist', ros_tools.twist([0, 0, 0], [0, 0, 0], frame_id=''),
     'unknown frame_id'),
    ('offset', 'set_twist', ros_tools.twist([0, math.inf, 0], [0, 0, 0]), 'non-finite'),
    ('offset', 'set_twist', ros_tools.twist([1e308, 0, 0], [0, 0, 0]), 'linear.x is 1e+308'),
    ('offset', 'set_twist', ros_tools.twist([0, 0, 0], [1e200, 0, 0]), 'angular.x is 1e+200'),
    ('offset', 'set_pose', ros_tools.pose([0, 0, 5e-324], [0, 0, 0, 1]),
     'position.z is 4.94e-324, a subnormal number: write floats (15.0)'),
    ('offset', 'set_pose', ros_tools.pose([0, 0, 0], [0, 0, 0, 1], frame_id='x' * 10_000),
     "unknown frame_id 'xxxx"),
    ('offset', 'set_twist', ros_tools.twist([0, 0, 0], [0, 0, 0], frame_id='x' * 10_000),
     '...(10000 characters)...'),
    ('offset', 'set_pose', ros_tools.pose([0, 0, 0], [0, 0, 0, 1], frame_id='x' * 100_000),
     'a PoseStamped of 100'),
])
def test_refused_state_over_ros_changes_nothing_and_is_counted(paused, body, topic, message,
                                                               reason):
    """A refused set_pose or set_twist changes no body, is counted and named, quoted short.

    Nothing non-finite is published after it: the bodies keep the state they had.
    """
    sim, probe = paused
    before = [probe.state(name) for name in ('offset', 'ball')]
    probe.send(body, topic, message)
    sim.step(3)
    for name, state in zip(('offset', 'ball'), before):
        for now, then in zip(probe.state(name), state):
            np.testing.assert_array_equal(now, then)
    twists = probe.heard['offset/twist']
    assert all(np.isfinite([t.twist.linear.x, t.twist.angular.x]).all() for t in twists)
    values = probe.diagnostics.values()
    assert values['refused inputs offset'] == '1' and values['refused inputs'] == '1'
    assert reason in values['last refused input']
    assert values['last refused input'].startswith('~/offset/set_')
    assert len(values['last refused input']) < 400
    assert math.isfinite(float(values['energy [J]']))
