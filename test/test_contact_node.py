# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's ~/contacts: the ground and the contacts of the last step, for RViz."""
from visualization_msgs.msg import Marker, MarkerArray

import ros_tools

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
