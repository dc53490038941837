# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Frames: the transforms for tf, frame_prefix, and markers cleared on a scene reload.

/tf and /tf_static are received as TFMessages built from the Jazzy definitions
(``rigid_sim_build_interfaces``); the node is also checked to run without tf2_msgs.
"""
import numpy as np
import pytest
import yaml
from visualization_msgs.msg import Marker

import ros_tools
from rigid_sim import conversions
from rigid_sim.core.scene import build_world, parse_scene
from rigid_sim.node import RigidSimNode

SCENE = """
bodies:
  - name: box
    shape: {type: box, size: [0.4, 0.2, 0.1]}
    mass: 2.0
    pose: {position: [1.0, 2.0, 3.0], orientation: [0.0, 0.0, 0.38268343, 0.92387953]}
    twist: {angular: [0.0, 0.0, 1.0]}
    points: {thruster: [-0.2, 0.0, 0.0], top: [0.0, 0.0, 0.05]}
    imu: {point: [0.1, 0.05, 0.0]}
  - name: ball
    shape: {type: sphere, radius: 0.1}
    mass: 1.0
    pose: {position: [0.0, -1.0, 0.0]}
    imu: {point: top}
    points: {top: [0.0, 0.0, 0.1]}
"""


def test_body_transforms_carry_the_published_poses_under_prefixed_frames():
    from rclpy.serialization import deserialize_message
    from rigid_sim.tf_output import TFMessage, serialized_transforms
    scene = parse_scene(yaml.safe_load(SCENE))
    world = build_world(scene, 'rk4')
    messages = conversions.StateMessages(scene.bodies, 'world', 'sim1/')
    snapshot = world.snapshot()
    messages.fill(snapshot, range(2), range(2))
    tf = serialized_transforms(messages.transforms, messages.stamp)
    tf.write(snapshot.frames, messages.stamp)
    sent = deserialize_message(_published(tf), TFMessage).transforms
    assert [t.child_frame_id for t in sent] == ['sim1/box', 'sim1/ball']
    assert [m.child_frame_id for m in messages.odometry] == ['sim1/box', 'sim1/ball']
    for transform, pose in zip(sent, messages.poses):
        assert transform.header.frame_id == 'world'
        assert transform.header.stamp == pose.header.stamp
        t, r = transform.transform.translation, transform.transform.rotation
        p, q = pose.pose.position, pose.pose.orientation
        assert (t.x, t.y, t.z, r.x, r.y, r.z, r.w) == (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    np.testing.assert_allclose([sent[0].transform.translation.x,
                                sent[0].transform.translation.y], [1.0, 2.0])


def _published(serialized):
    """Return the bytes ``serialized`` hands its publisher."""
    class Publisher:
        def publish(self, data):
            self.data = data
    publisher = Publisher()
    serialized.publish(publisher)
    return publisher.data


def test_static_transforms_place_every_point_and_imu_frame_on_its_body():
    """Static transforms place <body>/<point> at the point's body-frame coordinates.

    They carry no rotation; an IMU given by coordinates adds <body>/imu, one at a named
    point adds nothing new.
    """
    scene = parse_scene(yaml.safe_load(SCENE))
    statics = conversions.static_transforms(scene.bodies, 'sim1/', 0.0)
    found = {(t.header.frame_id, t.child_frame_id): t.transform for t in statics}
    assert sorted(found) == [('sim1/ball', 'sim1/ball/top'), ('sim1/box', 'sim1/box/imu'),
                             ('sim1/box', 'sim1/box/thruster'), ('sim1/box', 'sim1/box/top')]
    for (_, child), transform in found.items():
        t, r = transform.translation, transform.rotation
        body, point = child.split('/')[1:]
        expected = {'thruster': [-0.2, 0.0, 0.0], 'imu': [0.1, 0.05, 0.0],
                    'top': [0.0, 0.0, 0.05 if body == 'box' else 0.1]}[point]
        assert [t.x, t.y, t.z] == expected
        assert (r.x, r.y, r.z, r.w) == (0.0, 0.0, 0.0, 1.0)


def test_tf_carries_every_body_pose_and_tf_static_every_point_frame(rigid_sim):
    """/tf has world -> body at the published poses; /tf_static, latched, the point frames."""
    from tf2_msgs.msg import TFMessage
    from rigid_sim.tf_output import STATIC_QOS, TF_QOS
    sim = rigid_sim(yaml=SCENE, frame_prefix='sim1/')
    probe = ros_tools.Probe(sim, 'box')
    received = {'/tf': [], '/tf_static': []}
    for topic, qos in (('/tf', TF_QOS), ('/tf_static', STATIC_QOS)):
        probe.node.create_subscription(TFMessage, topic, received[topic].append, qos)
    sim.node.refresh_listeners()
    sim.step(1)
    statics = {(t.header.frame_id, t.child_frame_id)
               for t in received['/tf_static'][-1].transforms}
    assert ('sim1/box', 'sim1/box/thruster') in statics and len(statics) == 4
    box, ball = received['/tf'][-1].transforms
    assert (box.header.frame_id, box.child_frame_id, ball.child_frame_id) == (
        'world', 'sim1/box', 'sim1/ball')
    t, r = box.transform.translation, box.transform.rotation
    pose = probe.latest('box/pose')
    p, q = pose.pose.position, pose.pose.orientation
    assert box.header.stamp == pose.header.stamp
    assert (t.x, t.y, t.z, r.x, r.y, r.z, r.w) == (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    assert [t.x, t.y, t.z] == [1.0, 2.0, 3.0]  # spinning in place about z


def test_node_runs_without_tf2_msgs_and_says_how_to_add_it_once(
        ros_context, write_scene, capfd, monkeypatch):
    """Where tf2_msgs is missing (a venv without the interface build) tf is off, once said."""
    from rigid_sim import tf_output
    monkeypatch.setattr(tf_output, 'TFMessage', None)
    node = RigidSimNode(context=ros_context, cli_args=['--ros-args', '-p',
                                                       f'scene:={write_scene(SCENE)}'])
    node.loop.stop()
    for _ in range(3):
        node.tick()
    assert not node.outputs.tf_available
    said = capfd.readouterr().err
    assert said.count('/tf and /tf_static are off') == 1
    assert 'rigid_sim_build_interfaces' in said
    node.destroy_node()


def test_frame_prefix_names_frames_in_messages_and_wrenches_may_use_it(rigid_sim):
    """Odometry child and IMU frames carry the prefix, and wrench frames may use it.

    A body-axes force f = (0, 1, 0) N at 'sim1/box/thruster', p = (-0.2, 0, 0), acts at the
    thruster: paused, the box's IMU at r = (0.1, 0.05, 0) reads the specific force
    f / m + alpha x r + omega x (omega x r) with alpha = I^-1 (p x f) (the spin (0, 0, 1)
    is about a principal axis: no gyroscopic term), all in box axes.
    """
    sim = rigid_sim(yaml=SCENE, frame_prefix='sim1/', time_step=1 / 64, wrench_timeout=0.0)
    probe = ros_tools.Probe(sim, 'box')
    sim.pause()
    probe.push('box', 'sim1/box/thruster', [0.0, 1.0, 0.0])
    sim.step(1)
    assert probe.latest('box/odom').child_frame_id == 'sim1/box'
    reading = sim.imu('box')
    assert reading.frame_id == 'sim1/box/imu'
    properties = sim.properties('box')
    lever, force, spin = np.array([0.1, 0.05, 0.0]), np.array([0.0, 1.0, 0.0]), [0, 0, 1.0]
    alpha = np.linalg.solve(properties.inertia, np.cross([-0.2, 0.0, 0.0], force))
    expected = (force / properties.mass + np.cross(alpha, lever)
                + np.cross(spin, np.cross(spin, lever)))
    np.testing.assert_allclose(reading.linear_acceleration, expected, rtol=0, atol=1e-12)
    assert probe.diagnostics.values()['refused inputs'] == '0'


@pytest.mark.parametrize('prefix', ['/sim1/', 'sim 1', 'a//b'])
def test_bad_frame_prefix_is_refused(rigid_sim, prefix):
    """Refused with the reason; the parameter and the published frames stay as they were."""
    sim = rigid_sim(yaml=SCENE)
    probe = ros_tools.Probe(sim, 'box')
    result, = sim.set_parameters(frame_prefix=prefix)
    assert not result.successful and 'frame_prefix' in result.reason
    assert sim.node.get_parameter('frame_prefix').value == ''
    sim.step(1)
    assert probe.latest('box/odom').child_frame_id == 'box'
    assert sim.imu('box').frame_id == 'box/imu'


def test_scene_reload_clears_the_old_markers_first(rigid_sim, write_scene):
    """A reload sends one DELETEALL marker, then the new scene's markers."""
    sim = rigid_sim(yaml=SCENE)
    probe = ros_tools.Probe(sim)
    sim.step(1)
    one_body = write_scene('bodies:\n  - {name: cube, shape: {type: box, size: [1, 1, 1]}, '
                           'mass: 1.0}\n', 'one.yaml')
    markers = probe.heard['markers']
    assert sim.set_parameters(scene=one_body)[0].successful
    assert len(markers) == 2   # delivered before set_parameters returns
    assert [m.action for m in markers[1].markers] == [Marker.DELETEALL]
    sim.step(1)
    assert [m.ns for m in markers[-1].markers] == ['cube']


def test_a_change_of_frame_names_is_made_beside_and_swapped_in(rigid_sim, monkeypatch):
    """Every body's messages are rebuilt for new frame names in the owner's worker thread.

    Built in the parameter call, 10 000 bodies' messages held control for 3-6 s. Until the
    swap, everything published keeps the old names; after it, the new ones.
    """
    import threading
    from rigid_sim.outputs import StateOutputs
    made_in = []
    original = StateOutputs.frame_messages

    def recorded(self, *arguments):
        made_in.append(threading.current_thread())
        return original(self, *arguments)
    sim = rigid_sim(yaml=SCENE)
    monkeypatch.setattr(StateOutputs, 'frame_messages', recorded)
    probe = ros_tools.Probe(sim, 'box')
    assert all(r.successful for r in sim.set_parameters(frame_prefix='sim2/',
                                                        world_frame='map'))
    assert made_in and threading.main_thread() not in made_in
    sim.step(1)
    odometry = probe.latest('box/odom')
    assert (odometry.header.frame_id, odometry.child_frame_id) == ('map', 'sim2/box')
    assert sim.imu('box').frame_id == 'sim2/box/imu'
