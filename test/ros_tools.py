# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Helpers of the tests that speak ROS: messages to send, what was received, waiting.

The node itself is driven by the public test kit (``rigid_sim`` fixture); these only build
the messages a user's node would send and read back what a user's node received. Imported
by the tests as ``ros_tools`` (pytest puts ``test/`` on sys.path).
"""
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped, WrenchStamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from visualization_msgs.msg import MarkerArray

from rigid_sim import conversions

TIMEOUT = 60.0  # s; first discovery between processes takes seconds, more on a loaded machine


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
    _set(message.wrench.force, force)
    _set(message.wrench.torque, torque)
    return message


def pose(position, orientation, frame_id='world'):
    """Return a PoseStamped (orientation x, y, z, w) in ``frame_id``."""
    message = PoseStamped()
    message.header.frame_id = frame_id
    _set(message.pose.position, position)
    q = message.pose.orientation
    q.x, q.y, q.z, q.w = (float(v) for v in orientation)
    return message


def twist(linear, angular, frame_id='world'):
    """Return a TwistStamped in ``frame_id``."""
    message = TwistStamped()
    message.header.frame_id = frame_id
    _set(message.twist.linear, linear)
    _set(message.twist.angular, angular)
    return message


def _set(vector, values):
    """Write three values into a Vector3 or Point, as floats (an int would not do)."""
    vector.x, vector.y, vector.z = (float(v) for v in values)


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
    """The simulator's /diagnostics, as ``node`` (of the test) hears them.

    The node publishes them once a second of wall time; :meth:`now` has it publish at once.
    """

    def __init__(self, sim, node):
        self._sim = sim
        self.heard = record(node, DiagnosticArray, '/diagnostics')

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


class Probe:
    """A node of the test beside a kit simulation: hears its outputs, sends it inputs.

    Parameters
    ----------
    sim : rigid_sim.testing.Simulation
    *bodies : str
        The bodies whose pose, twist and odometry it hears; it also hears /clock, ~/poses
        and ~/markers.
    """

    def __init__(self, sim, *bodies):
        self.sim = sim
        self.node = sim.create_node('probe')
        self.heard = {'/clock': record(self.node, Clock, '/clock')}
        self.listen(*bodies)
        self._publishers = {}
        self.diagnostics = Diagnostics(sim, self.node)

    def listen(self, *bodies):
        """Hear ~/poses, ~/markers and the pose, twist and odometry of ``bodies`` too."""
        topics = {'poses': PoseArray, 'markers': MarkerArray}
        for body in bodies:
            topics.update({f'{body}/pose': PoseStamped, f'{body}/twist': TwistStamped,
                           f'{body}/odom': Odometry})
        for topic, kind in topics.items():
            if topic not in self.heard:
                self.heard[topic] = record(self.node, kind, self.sim.topic(topic))

    def latest(self, topic):
        """Return the last message heard on ``topic`` (relative to the simulator, or /name)."""
        return self.heard[topic][-1]

    def stamps(self, topic):
        """Return the times (s) stamped on every message heard on ``topic``."""
        return [conversions.to_seconds(m.clock if topic == '/clock' else m.header.stamp)
                for m in self.heard[topic]]

    def state(self, body):
        """Position, orientation, velocity, angular velocity, time, as last published."""
        return published_state(self.heard[f'{body}/pose'], self.heard[f'{body}/twist'])

    def send(self, body, topic, message):
        """Publish ``message`` on the simulator's ``<body>/<topic>``; it acts at the next tick.

        A new publisher is first matched with the simulator's subscription (the kit's
        connect), since a message sent before that is lost.
        """
        key = (body, topic)
        if key not in self._publishers:
            self._publishers[key] = self.node.create_publisher(
                type(message), self.sim.topic(f'{body}/{topic}'), 10)
            self.sim.connect()
        self._publishers[key].publish(message)

    def push(self, body, frame_id, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)):
        """Send a wrench on ``<body>/wrench``."""
        self.send(body, 'wrench', wrench(frame_id, force, torque))
