# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's ~/contacts: the ground and the contacts of the last step, for RViz."""
from visualization_msgs.msg import Marker, MarkerArray

import ros_tools
from rigid_sim.testing.simulation import PREPARATION_TIMEOUT

SCENE = """
effects:
  gravity: {acceleration: [0.0, 0.0, -9.81]}
  contact: {planes: [{normal: [0.0, 0.0, 1.0], offset: 0.0}]}
bodies:
  - {name: ball, shape: {type: sphere, radius: 0.1}, mass: 1.0,
     pose: {position: [0.5, -0.25, 0.1]}}
"""


def test_a_resting_ball_shows_its_contact_and_the_ground(rigid_sim):
    """A ball resting on z = 0 touches it below its centre, pushed up along +z.

    Contacts are found where a tick's fall ended: the point lies midway into the
    penetration of one tick's fall from rest, ``g dt^2 / 2`` (dt = 0.01 s, the default).
    """
    sim = rigid_sim(yaml=SCENE)
    heard = ros_tools.record(sim.create_node('contact_probe'), MarkerArray,
                             sim.topic('contacts'))
    sim.connect()
    sim.step(3)
    markers = heard[-1].markers
    assert markers[0].action == Marker.DELETEALL
    ground, = [m for m in markers if m.ns == 'ground']
    assert ground.type == Marker.CUBE and abs(ground.pose.position.z) < 1e-12
    arrow, = [m for m in markers if m.ns == 'contacts']
    start, tip = arrow.points
    assert (abs(start.x - 0.5) < 1e-9 and abs(start.y + 0.25) < 1e-9
            and abs(start.z) <= 9.81 * 0.01 ** 2 / 2)
    assert abs(tip.x - start.x) < 1e-12 and tip.z > start.z


BOX_URDF = """<robot name="crate"><link name="crate">
  <inertial><mass value="2.0"/>
    <inertia ixx="0.01333" iyy="0.01333" izz="0.01333" ixy="0" ixz="0" iyz="0"/></inertial>
  <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
</link></robot>"""


def test_bodies_spawned_onto_the_ground_rest_there(rigid_sim):
    """A URDF box and a YAML ball spawned touching z = 0 stay there, at rest, for 2 s.

    Resting contact holds a body's weight with no approach speed: neither sinks (more than
    one tick's fall, ``g dt^2 / 2``) nor bounces, and no sliding starts from rest.
    """
    from simulation_interfaces.msg import Result
    from simulation_interfaces.srv import SpawnEntity
    sim = rigid_sim(yaml=SCENE)
    box = SpawnEntity.Request(resource_string=BOX_URDF)
    box.initial_pose.pose.position.x, box.initial_pose.pose.position.z = -1.0, 0.1
    ball = SpawnEntity.Request(resource_string='{name: pebble, shape: {type: sphere, '
                               'radius: 0.05}, mass: 0.2, pose: {position: [1.0, 0.0, 0.05]}}')
    for request in (box, ball):   # the first compiles the new world's kernels if not cached
        answer = sim.call(SpawnEntity, 'spawn_entity', request, timeout=PREPARATION_TIMEOUT)
        assert answer.result.result == Result.RESULT_OK
    sim.step(200)
    for name, height in (('crate', 0.1), ('pebble', 0.05)):
        state = sim.state(name)
        assert abs(state.position[2] - height) <= 9.81 * 0.01 ** 2 / 2, name
        assert abs(abs(state.position[0]) - 1.0) < 1e-9 and abs(state.position[1]) < 1e-9, name
        assert abs(state.velocity).max() < 1e-6 and abs(state.angular_velocity).max() < 1e-6
