# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Helpers of the tests that speak ROS: messages to send, what was received, waiting.

The node itself is driven by the public test kit (``rigid_sim`` fixture); these only build
the messages a user's node would send and read back what a user's node received. Imported
by the tests as ``ros_tools`` (pytest puts ``test/`` on sys.path).
"""
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped

from rigid_sim import conversions

TIMEOUT = 15.0  # s; first discovery between processes can take seconds (docs/ros_notes.md)


def spin_until(executor, condition, timeout=TIMEOUT, what='condition'):
    """Spin ``executor`` until ``condition()`` is true; AssertionError after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f'{what} not reached within {timeout} s')
        executor.spin_once(timeout_sec=0.05)


def record(node, kind, topic):
    """Subscribe ``node`` to ``topic``; the list every message received is appended to."""
    received = []
    node.create_subscription(kind, topic, received.append, 100)
    return received


def wrench(frame_id, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)):
    """Return a WrenchStamped in ``frame_id``."""
    message = WrenchStamped()
    message.header.frame_id = frame_id
    w = message.wrench
    w.force.x, w.force.y, w.force.z = (float(f) for f in force)
    w.torque.x, w.torque.y, w.torque.z = (float(t) for t in torque)
    return message


def pose(position, orientation, frame_id='world'):
    """Return a PoseStamped (orientation x, y, z, w) in ``frame_id``."""
    message = PoseStamped()
    message.header.frame_id = frame_id
    p, q = message.pose.position, message.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    q.x, q.y, q.z, q.w = (float(v) for v in orientation)
    return message


def twist(linear, angular, frame_id='world'):
    """Return a TwistStamped in ``frame_id``."""
    message = TwistStamped()
    message.header.frame_id = frame_id
    t = message.twist
    t.linear.x, t.linear.y, t.linear.z = (float(v) for v in linear)
    t.angular.x, t.angular.y, t.angular.z = (float(v) for v in angular)
    return message


def published_state(poses, twists):
    """Position, orientation, velocity, angular velocity and time from the latest messages.

    ``poses`` and ``twists`` are the PoseStamped and TwistStamped received for one body.
    """
    pose_message, twist_message = poses[-1], twists[-1]
    position, orientation = conversions.pose_arrays(pose_message.pose)
    return (position, orientation, conversions.vector_array(twist_message.twist.linear),
            conversions.vector_array(twist_message.twist.angular),
            conversions.to_seconds(pose_message.header.stamp))


class Diagnostics:
    """The simulator's /diagnostics, as a node of the test hears them.

    The node publishes them once a second of wall time; :meth:`now` has it publish at once.
    """

    def __init__(self, sim):
        self._sim = sim
        self.heard = record(sim.create_node('diagnostics_listener'), DiagnosticArray,
                            '/diagnostics')

    def now(self):
        """Have the simulator publish its status now; that status (level, message, values)."""
        self._sim.connect()
        count = len(self.heard)
        self._sim.node.publish_diagnostics()
        self._sim.step(0)
        assert len(self.heard) > count, 'no /diagnostics received'
        return self.heard[-1].status[0]

    def values(self):
        """Have the simulator publish its status now; its key -> text values."""
        return {item.key: item.value for item in self.now().values}
