# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's physics as seen over ROS: inputs in, exact state out, services.

Each test starts the node with the public test kit and a probe node of its own, advances
the node tick by tick (``sim.step``) and checks what the probe received against physics
worked out here. Time steps are binary fractions (1/8, 1/64 s) so that simulated times add
up exactly.
"""
import math
import re
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from scipy.integrate import quad
from scipy.spatial.transform import Rotation
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import Marker

import ros_tools
from rigid_sim import conversions

MASS = 2.0                        # kg, the box
SIZE = np.array([0.4, 0.2, 0.1])  # m, the box
X0 = np.array([1.0, -2.0, 0.5])   # m, initial position of the box
V0 = np.array([0.3, 0.0, -0.1])   # m/s, initial velocity of the box
THRUSTER = np.array([-0.2, 0.0, 0.0])  # m, body frame; the box's centre of mass is its origin
MAX_FORCE, MAX_TORQUE = 100.0, 10.0
BALL_MASS, BALL_RADIUS, BALL_SPIN = 1.0, 0.1, np.array([0.0, 0.0, 3.0])
STEP = 0.125  # s, exact in binary

SCENE = f"""
world_frame: world
limits: {{max_force: {MAX_FORCE}, max_torque: {MAX_TORQUE}}}
bodies:
  - name: box
    shape: {{type: box, size: {SIZE.tolist()}}}
    mass: {MASS}
    pose: {{position: {X0.tolist()}}}
    twist: {{linear: {V0.tolist()}}}
    points: {{thruster: {THRUSTER.tolist()}}}
  - name: ball
    shape: {{type: sphere, radius: {BALL_RADIUS}}}
    mass: {BALL_MASS}
    pose: {{position: [0.0, 1.0, 0.0]}}
    twist: {{angular: {BALL_SPIN.tolist()}}}
    wrench_input: false
  - name: rod
    shape: {{type: cylinder, radius: 0.05, length: 1.0}}
    mass: 1.0
    pose: {{position: [0.0, -1.0, 0.0]}}
"""
# RK4 integrates constant-force motion (a polynomial of degree 2) exactly; the tests of the
# node's wiring should not depend on which integrator is the default.
EXACT_FOR_CONSTANT_FORCE = {'integrator': 'rk4'}


BODIES = ('box', 'ball', 'rod')


def started(rigid_sim, scene=SCENE, **parameters):
    """Start ``scene`` in the kit, and a probe hearing every body's outputs."""
    sim = rigid_sim(yaml=scene, **parameters)
    return sim, ros_tools.Probe(sim, *BODIES)


@pytest.fixture
def box(rigid_sim):
    """Return the three-body scene, stepped by STEP per tick, wrenches held until replaced.

    As (simulation, probe).
    """
    return started(rigid_sim, time_step=STEP, wrench_timeout=0.0, **EXACT_FOR_CONSTANT_FORCE)


def free_flight(force, t, x0=X0, v0=V0):
    """Position and velocity of the box under a constant world ``force`` for ``t`` s."""
    force = np.asarray(force, dtype=float)
    return x0 + v0 * t + force * t ** 2 / (2 * MASS), v0 + force * t / MASS


def test_world_force_at_centre_of_mass_accelerates_by_force_over_mass(box):
    """A constant world force F at the centre of mass gives x = x0 + v0 t + F t^2 / 2M."""
    sim, probe = box
    force = [3.0, -1.0, 2.0]
    probe.push('box', 'world', force)
    sim.step(8)
    position, orientation, velocity, angular_velocity, t = probe.state('box')
    expected_position, expected_velocity = free_flight(force, 1.0)
    assert t == 1.0
    np.testing.assert_allclose(position, expected_position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(velocity, expected_velocity, rtol=0, atol=1e-12)
    np.testing.assert_allclose(orientation, [0, 0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(angular_velocity, 0.0, atol=1e-15)


def test_body_force_at_named_point_torques_by_lever_cross_force(rigid_sim):
    """A body-axes force f at point p gives torque (p - x) x f and turns with the body.

    Box at rest, f = (0, 1, 0) N in box axes at the thruster (-0.2, 0, 0): the torque
    about z is -0.2 N m, so omega_z = -0.2 t / Izz and theta = -0.1 t^2 / Izz with
    Izz = M (a^2 + b^2) / 12. The force turns with the box: in world axes it is
    (-sin theta, cos theta, 0), and the momentum is its integral over time.
    """
    still = SCENE.replace(f'twist: {{linear: {V0.tolist()}}}', '')
    sim, probe = started(rigid_sim, still, time_step=1 / 64, wrench_timeout=0.0,
                         **EXACT_FOR_CONSTANT_FORCE)
    probe.push('box', 'box/thruster', [0.0, 1.0, 0.0])
    sim.step(32)
    position, orientation, velocity, angular_velocity, t = probe.state('box')
    inertia_z = MASS * (SIZE[0] ** 2 + SIZE[1] ** 2) / 12
    torque_z = np.cross(THRUSTER, [0.0, 1.0, 0.0])[2]
    assert torque_z == pytest.approx(-0.2)

    def angle(s):
        return 0.5 * torque_z * s ** 2 / inertia_z

    def world_velocity(s):
        return np.array([quad(lambda u: -math.sin(angle(u)), 0, s)[0],
                         quad(lambda u: math.cos(angle(u)), 0, s)[0], 0.0]) / MASS

    displacement = [quad(lambda s: world_velocity(s)[i], 0, t)[0] for i in range(2)]
    np.testing.assert_allclose(angular_velocity, [0, 0, torque_z * t / inertia_z], atol=1e-12)
    expected_orientation = Rotation.from_rotvec([0, 0, angle(t)]).as_quat()
    np.testing.assert_allclose(orientation, expected_orientation, atol=1e-6)
    np.testing.assert_allclose(velocity, world_velocity(t), atol=1e-6)
    np.testing.assert_allclose(position[:2], X0[:2] + displacement, atol=1e-6)
    assert position[2] == X0[2]


def test_wrenches_from_two_frames_add_and_same_frame_replaces(box):
    """Forces from frame_ids 'world' and '' act together; a new 'world' one replaces the old.

    No torque acts, so body axes stay world axes and the accelerations are (F1 + F2) / M.
    """
    sim, probe = box
    world_force, body_force, new_world_force = [1.0, 0, 0], [0, 2.0, 0], [0, 0, -4.0]
    probe.push('box', 'world', world_force)
    probe.push('box', '', body_force)
    sim.step(4)
    x_half, v_half = free_flight(np.add(world_force, body_force), 0.5)
    np.testing.assert_allclose(probe.state('box')[0], x_half, atol=1e-12)
    probe.push('box', 'world', new_world_force)
    sim.step(4)
    expected = free_flight(np.add(new_world_force, body_force), 0.5, x_half, v_half)
    position, _, velocity, _, _ = probe.state('box')
    np.testing.assert_allclose(position, expected[0], atol=1e-12)
    np.testing.assert_allclose(velocity, expected[1], atol=1e-12)


def test_a_flood_within_one_tick_applies_only_the_newest_per_frame_and_counts_the_rest(box):
    """Apply only the newest of five 'world' and two '' pushes sent before one tick.

    Their sum over M accelerates the box; the other five are superseded, not refused.
    """
    sim, probe = box
    for force in ([50.0, 0, 0], [0, 50.0, 0], [0, 0, 50.0], [-50.0, 0, 0], [1.0, 0, 0]):
        probe.push('box', 'world', force)
    probe.push('box', '', [0, 50.0, 0])
    probe.push('box', '', [0, 2.0, 0])
    sim.step(4)
    x_half, v_half = free_flight([1.0, 2.0, 0.0], 0.5)
    position, _, velocity, _, _ = probe.state('box')
    np.testing.assert_allclose(position, x_half, atol=1e-12)
    np.testing.assert_allclose(velocity, v_half, atol=1e-12)
    values = probe.diagnostics.values()
    assert values['superseded inputs'] == '5' and values['refused inputs'] == '0'


def test_held_wrench_stops_after_timeout(rigid_sim):
    """A wrench held for wrench_timeout T of simulated time delivers the impulse F T, no more."""
    sim, probe = started(rigid_sim, time_step=STEP, wrench_timeout=0.5,
                         **EXACT_FOR_CONSTANT_FORCE)
    force = np.array([0.0, 4.0, 0.0])
    probe.push('box', 'world', force)
    sim.step(4)
    np.testing.assert_allclose(probe.state('box')[2], V0 + force * 0.5 / MASS, atol=1e-12)
    sim.step(4)
    x_half, v_half = free_flight(force, 0.5)
    position, _, velocity, _, t = probe.state('box')
    assert t == 1.0
    np.testing.assert_allclose(velocity, v_half, atol=1e-12)
    np.testing.assert_allclose(position, x_half + v_half * 0.5, atol=1e-12)


@pytest.mark.parametrize('frame_id, force, torque, reason', [
    ('world', [math.nan, 0, 0], [0, 0, 0], 'non-finite'),
    ('box', [0, 0, 0], [0, math.inf, 0], 'non-finite'),
    ('box/nowhere', [1.0, 0, 0], [0, 0, 0], 'unknown frame_id'),
    ('world', [MAX_FORCE * 1.01, 0, 0], [0, 0, 0], 'max_force'),
    ('box', [0, 0, 0], [0, 0, MAX_TORQUE * 1.01], 'max_torque'),
    ('world', [MAX_FORCE + 1e-4, 0, 0], [0, 0, 0], f'{MAX_FORCE + 1e-4!r} N above'),
    ('world', [1e300, 1e300, 0], [0, 0, 0], 'max_force'),
    ('world', [15 * 5e-324, 0, 0], [0, 0, 0], r'write floats \(15\.0\): an int'),
    ('box', [0, 0, 0], [0, -5e-324, 0], 'torque.y .* subnormal'),
    ('x' * 10_000, [1.0, 0, 0], [0, 0, 0], r'unknown frame_id .*\(10000 characters\)'),
    ('x' * 100_000, [1.0, 0, 0], [0, 0, 0],
     r'a WrenchStamped of 100\d{3} bytes serialised, above the 65536 .* not read'),
])
def test_refused_wrench_changes_nothing_and_is_counted(box, frame_id, force, torque, reason):
    """A refused wrench neither acts nor replaces the wrench held under its frame_id.

    Its reason is quoted short and no numpy warning (overflow of 1e300 squared) is raised.
    """
    sim, probe = box
    held = [2.0, 0.0, 0.0]
    probe.push('box', 'world', held)
    sim.step(4)
    with warnings.catch_warnings():
        warnings.simplefilter('error', RuntimeWarning)
        probe.push('box', frame_id, force, torque)
        sim.step(4)
    position, orientation, velocity, angular_velocity, _ = probe.state('box')
    expected_position, expected_velocity = free_flight(held, 1.0)
    np.testing.assert_allclose(position, expected_position, atol=1e-12)
    np.testing.assert_allclose(velocity, expected_velocity, atol=1e-12)
    np.testing.assert_allclose(orientation, [0, 0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(angular_velocity, 0.0, atol=1e-15)
    values = probe.diagnostics.values()
    assert values['refused inputs'] == '1'
    assert values['refused inputs box'] == '1'
    assert re.search(reason, values['last refused input']), values['last refused input']
    assert len(values['last refused input']) < 1000


def test_pause_freezes_time_and_pose_while_topics_keep_coming(box):
    """Paused, every tick still publishes, at the same simulated time and the same pose."""
    sim, probe = box
    probe.push('box', 'world', [1.0, 1.0, 1.0])
    sim.step(2)
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    frozen = probe.state('box')
    received = len(probe.heard['box/pose'])
    sim.step(3)
    assert len(probe.heard['box/pose']) == received + 3
    for now, before in zip(probe.state('box'), frozen):
        np.testing.assert_array_equal(now, before)
    assert conversions.to_seconds(probe.latest('/clock').clock) == 2 * STEP
    assert sim.call(SetBool, 'pause', SetBool.Request(data=False)).success
    sim.step(1)
    expected_position, _ = free_flight([1.0, 1.0, 1.0], 3 * STEP)
    np.testing.assert_allclose(probe.state('box')[0], expected_position, atol=1e-12)


def test_reset_returns_initial_state_at_time_zero_and_drops_wrenches(box):
    """After reset: time 0, the scene's initial pose and twist, and no held wrench acts."""
    sim, probe = box
    probe.push('box', 'box/thruster', [0.0, 5.0, 0.0])
    sim.step(4)
    assert sim.call(Trigger, 'reset', Trigger.Request()).success
    assert sim.call(SetBool, 'pause', SetBool.Request(data=True)).success
    sim.step(1)
    position, orientation, velocity, angular_velocity, t = probe.state('box')
    assert t == 0.0
    np.testing.assert_array_equal(position, X0)
    np.testing.assert_array_equal(orientation, [0, 0, 0, 1])
    np.testing.assert_array_equal(velocity, V0)
    np.testing.assert_array_equal(angular_velocity, [0, 0, 0])
    assert sim.call(SetBool, 'pause', SetBool.Request(data=False)).success
    sim.step(4)
    position, orientation, velocity, _, t = probe.state('box')
    assert t == 0.5
    np.testing.assert_allclose(position, X0 + V0 * t, atol=1e-12)
    np.testing.assert_allclose(velocity, V0, atol=1e-12)


def test_odometry_twist_and_pose_agree_for_a_body_with_offset_centre_of_mass(rigid_sim):
    """PoseStamped, TwistStamped and Odometry describe one motion of the body frame.

    The L block's centre of mass is off its frame origin, so the origin's velocity differs
    from the centre of mass's by omega x (origin - com). Central differences of the
    published poses over 2 dt must match the published world twist to O(dt^2), and the
    odometry twist is the same twist in body axes (REP-105): R^T v, R^T omega.
    """
    mesh = Path(__file__).resolve().parents[1] / 'config' / 'meshes' / 'l_block.obj'
    scene = (f"""
bodies:
  - name: l_block
    shape: {{type: mesh, file: {mesh}}}
    mass: 3.0
    pose: {{position: [0.1, 0.2, 0.3], orientation: [0.2, -0.1, 0.3, 0.9]}}
    twist: {{linear: [0.1, 0.0, -0.2], angular: [0.5, 1.0, 2.0]}}
""")
    step = 1e-3
    sim = rigid_sim(yaml=scene, time_step=step)
    probe = ros_tools.Probe(sim, 'l_block')
    assert np.linalg.norm(sim.properties('l_block').center_of_mass) > 0.05  # the premise
    sim.step(3)
    poses = [conversions.pose_arrays(m.pose) for m in probe.heard['l_block/pose']]
    twist = probe.heard['l_block/twist'][1].twist
    velocity = conversions.vector_array(twist.linear)
    angular_velocity = conversions.vector_array(twist.angular)
    (before, q_before), (_, q_middle), (after, q_after) = poses
    np.testing.assert_allclose((after - before) / (2 * step), velocity, atol=1e-5)
    turn = Rotation.from_quat(q_after) * Rotation.from_quat(q_before).inv()
    np.testing.assert_allclose(turn.as_rotvec() / (2 * step), angular_velocity, atol=1e-5)
    odometry = probe.heard['l_block/odom'][1]
    assert (odometry.header.frame_id, odometry.child_frame_id) == ('world', 'l_block')
    assert odometry.header.stamp == probe.heard['l_block/pose'][1].header.stamp
    assert odometry.pose.pose == probe.heard['l_block/pose'][1].pose
    world_from_body = Rotation.from_quat(q_middle).as_matrix()
    body_twist = odometry.twist.twist
    np.testing.assert_allclose(conversions.vector_array(body_twist.linear),
                               world_from_body.T @ velocity, atol=1e-12)
    np.testing.assert_allclose(conversions.vector_array(body_twist.angular),
                               world_from_body.T @ angular_velocity, atol=1e-12)
    marker, = probe.latest('markers').markers  # RViz draws the same mesh at the same pose
    assert (marker.type, marker.mesh_resource) == (Marker.MESH_RESOURCE, f'file://{mesh}')
    assert marker.pose == probe.latest('l_block/pose').pose


def test_pose_array_and_markers_show_every_body_in_scene_order(box):
    """Both PoseArray and MarkerArray list the bodies in scene order, with their shapes' sizes."""
    sim, probe = box
    sim.step(1)
    poses = probe.latest('poses').poses
    assert len(poses) == 3
    for pose, name in zip(poses, BODIES):
        assert pose == probe.latest(f'{name}/pose').pose
    markers = probe.latest('markers').markers
    assert [m.type for m in markers] == [Marker.CUBE, Marker.SPHERE, Marker.CYLINDER]
    assert [m.pose for m in markers] == list(poses)
    sizes = [conversions.vector_array(m.scale) for m in markers]
    np.testing.assert_allclose(sizes, [SIZE, [2 * BALL_RADIUS] * 3, [0.1, 0.1, 1.0]])


def test_diagnostics_report_energy_and_momentum_of_free_bodies(box):
    """Free bodies keep E = sum M v^2/2 + omega.I omega/2, P = sum M v, L = sum(I w + x x P)."""
    sim, probe = box
    sim.step(4)
    values = probe.diagnostics.values()
    ball_inertia = 0.4 * BALL_MASS * BALL_RADIUS ** 2
    energy = 0.5 * MASS * V0 @ V0 + 0.5 * ball_inertia * BALL_SPIN @ BALL_SPIN
    momentum = MASS * V0
    angular_momentum = np.cross(X0, momentum) + ball_inertia * BALL_SPIN
    assert float(values['energy [J]']) == pytest.approx(energy, rel=1e-12)
    np.testing.assert_allclose(np.fromstring(values['linear momentum [kg m/s]'], sep=' '),
                               momentum, atol=1e-12)
    np.testing.assert_allclose(
        np.fromstring(values['angular momentum about the world origin [kg m^2/s]'], sep=' '),
        angular_momentum, atol=1e-8)
    assert values['simulated time [s]'] == '0.5'


def test_step_that_stays_non_finite_is_given_up_keeping_the_last_good_state(rigid_sim):
    """RK4 on a spring with k/m = 1e30 needs omega h < 2.8, i.e. 4e13 substeps per 1/8 s tick.

    The spring is 1e15 N/m on 1e-15 kg, the extremes a scene may give. Capped at 1000 (and
    retried at up to 16000), each substep multiplies the state by about (omega h)^4 / 24 >> 1
    and overflows: the node keeps the initial state (finite, at t = 0), keeps publishing it,
    and /diagnostics reports ERROR.
    """
    scene = (f"""
effects:
  springs:
    - {{body: box, point: [0, 0, 0], anchor: [0.0, 0.0, 1.0], stiffness: 1.0e+15}}
bodies:
  - name: box
    shape: {{type: box, size: {SIZE.tolist()}}}
    mass: 1.0e-15
""")
    sim = rigid_sim(yaml=scene, time_step=STEP, integrator='rk4')
    probe = ros_tools.Probe(sim, 'box')
    sim.step(2)
    position, orientation, velocity, angular_velocity, t = probe.state('box')
    assert t == 0.0 and len(probe.heard['box/pose']) == 2   # published, at the kept state
    np.testing.assert_array_equal(position, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(velocity, [0.0, 0.0, 0.0])
    status = probe.diagnostics.now()
    values = {item.key: item.value for item in status.values}
    assert values['failed steps'] == '2'
    assert 'non-finite' in values['last step failure']
    assert status.level == DiagnosticStatus.ERROR


def test_output_gaining_a_subscriber_is_published_within_the_refresh_period(
        ros_context, write_scene):
    """Outputs nobody listens to are skipped.

    A subscriber that joins later gets the box's pose within LISTENER_REFRESH of wall time (plus
    spinning): free flight x0 + v0 t at the simulated time of its stamp. The node is made
    here, not by the test kit, whose step() asks who listens before every tick: this checks
    that the node finds new listeners by itself.
    """
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from rigid_sim.node import LISTENER_REFRESH, RigidSimNode
    from ros_tools import spin_until
    sim = RigidSimNode(context=ros_context, parameter_overrides=[
        Parameter('scene', value=write_scene(SCENE)), Parameter('time_step', value=STEP)])
    sim.loop.stop()
    late = Node('late', context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in (sim, late):
        executor.add_node(node)
    sim.tick()   # nobody listens yet
    received = []
    late.create_subscription(PoseStamped, f'{sim.get_fully_qualified_name()}/box/pose',
                             received.append, 10)
    joined = time.monotonic()
    spin_until(executor, lambda: sim.tick() or received, what='late subscriber served')
    assert time.monotonic() - joined < LISTENER_REFRESH + 0.5
    stamp = conversions.to_seconds(received[0].header.stamp)
    assert stamp > STEP
    position, _ = conversions.pose_arrays(received[0].pose)
    np.testing.assert_allclose(position, X0 + V0 * stamp, atol=1e-12)
    for node in (sim, late):
        node.destroy_node()
    executor.shutdown()


def test_clock_goes_out_only_while_someone_listens(ros_context, write_scene):
    """No /clock message is sent with no subscriber; one joining later gets every tick's time.

    Within LISTENER_REFRESH of wall time (plus spinning) it receives the simulated time of
    each tick from then on: a whole number of time steps, one step apart. The node is made
    here, not by the test kit, which asks who listens before every tick (see above).
    """
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rosgraph_msgs.msg import Clock

    from rigid_sim.node import LISTENER_REFRESH, RigidSimNode
    from ros_tools import spin_until
    sim = RigidSimNode(context=ros_context, parameter_overrides=[
        Parameter('scene', value=write_scene(SCENE)), Parameter('time_step', value=STEP)])
    sim.loop.stop()
    publisher = next(p for p in sim.publishers if p.topic_name == '/clock')
    sent, send = [], publisher.publish
    publisher.publish = lambda message: sent.append(message) or send(message)
    sim.tick()
    sim.tick()
    assert not sent
    late = Node('late', context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    for node in (sim, late):
        executor.add_node(node)
    received = []
    late.create_subscription(Clock, '/clock', received.append, 100)
    joined = time.monotonic()
    spin_until(executor, lambda: sim.tick() or len(received) >= 3, what='late /clock served')
    assert time.monotonic() - joined < LISTENER_REFRESH + 0.5
    ticks = [conversions.to_seconds(m.clock) / STEP for m in received]
    np.testing.assert_allclose(ticks, np.round(ticks), atol=1e-9)
    np.testing.assert_allclose(np.diff(ticks), 1.0, atol=1e-9)
    assert ticks[0] > 2.0
    for node in (sim, late):
        node.destroy_node()
    executor.shutdown()


def test_a_large_scene_makes_per_body_topics_when_they_are_used(rigid_sim):
    """Above per_body_topics_limit bodies, no per-body topic exists until someone uses it.

    ~/poses is there from the start; a subscriber to one body's pose gets that publisher
    made (and no other), a publisher on one body's wrench gets that subscription made, and
    the wrench acts: the box leaves with F t / M.
    """
    sim = rigid_sim(yaml=SCENE, time_step=STEP, wrench_timeout=0.0, per_body_topics_limit=2,
                    **EXACT_FOR_CONSTANT_FORCE)
    node = sim.node
    assert node.count_publishers(sim.topic('box/pose')) == 0
    assert node.count_subscribers(sim.topic('box/wrench')) == 0
    assert node.count_publishers(sim.topic('poses')) == 1
    probe = sim.create_node('probe')
    poses = ros_tools.record(probe, PoseStamped, sim.topic('box/pose'))
    twists = ros_tools.record(probe, TwistStamped, sim.topic('rod/twist'))
    deadline = time.monotonic() + ros_tools.TIMEOUT
    while not (poses and twists):   # made once the node has seen the subscriber
        assert time.monotonic() < deadline, 'box/pose and rod/twist made and received'
        sim.step(1)
    assert node.count_publishers(sim.topic('ball/pose')) == 0   # nobody listens to it
    push = probe.create_publisher(WrenchStamped, sim.topic('box/wrench'), 10)
    sim.connect()   # the node subscribes to box/wrench now that a publisher is there
    assert node.count_subscribers(sim.topic('box/wrench')) == 1
    push.publish(ros_tools.wrench('world', [4.0, 0.0, 0.0]))
    start = sim.time
    sim.step(1)
    np.testing.assert_allclose(sim.state('box').velocity,
                               V0 + np.array([4.0, 0, 0]) * (sim.time - start) / MASS,
                               atol=1e-12)
