# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A rigid_sim node and a probe node in one executor, driven tick by tick.

The probe talks to the node only over ROS: it subscribes to every output, publishes
wrenches and calls the services. Nothing sleeps to synchronise: :func:`spin_until` spins
until a condition holds, bounded by a timeout. Imported by the tests as ``ros_harness``
(pytest puts ``test/`` on sys.path).
"""
import time
from collections import defaultdict

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped, WrenchStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from visualization_msgs.msg import MarkerArray

from rigid_sim import conversions
from rigid_sim.node import RigidSimNode

TIMEOUT = 15.0  # s; first discovery between processes can take seconds (docs/ros_notes.md)


def spin_until(executor, condition, timeout=TIMEOUT, what='condition'):
    """Spin ``executor`` until ``condition()`` is true; AssertionError after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f'{what} not reached within {timeout} s')
        executor.spin_once(timeout_sec=0.05)


# s of wall time a scene or integrator change may take to prepare (compiling included)
PREPARATION_TIMEOUT = 600.0


class SimHarness:
    """The node under test (``sim``), a ``probe`` node, and what the probe received.

    Parameters
    ----------
    context : rclpy.Context
        The test's own context (discovery OFF).
    executor : rclpy.executors.Executor
        Spins both nodes.
    scene : str
        Scene file.
    params : dict
        Further parameter overrides of the node.
    ticking : bool
        Keep the node's own tick loop; by default it is stopped and the test advances the
        node with :meth:`tick`.
    """

    def __init__(self, context, executor, scene, params, ticking=False):
        overrides = [Parameter(name, value=value)
                     for name, value in dict(params, scene=scene).items()]
        self.sim = RigidSimNode(context=context, parameter_overrides=overrides)
        if not ticking:
            self.sim.loop.stop()
        self.probe = Node('probe', context=context)
        self.executor = executor
        executor.add_node(self.sim)
        executor.add_node(self.probe)
        self.received = defaultdict(list)
        self._publishers = {}
        self._subscriptions = []
        self.listen()

    def topic(self, name):
        """Absolute name of the node-relative topic ``name``."""
        return f'{self.sim.get_fully_qualified_name()}/{name}'

    def listen(self):
        """Subscribe to every output of the node's current scene; wait until matched."""
        for subscription in self._subscriptions:
            self.probe.destroy_subscription(subscription)
        topics = {'/clock': Clock, '/diagnostics': DiagnosticArray,
                  self.topic('poses'): PoseArray, self.topic('markers'): MarkerArray}
        for body in self.sim.scene.bodies:
            topics[self.topic(f'{body.name}/pose')] = PoseStamped
            topics[self.topic(f'{body.name}/twist')] = TwistStamped
            topics[self.topic(f'{body.name}/odom')] = Odometry
        self._subscriptions = [
            self.probe.create_subscription(kind, topic, self.received[topic].append, 100)
            for topic, kind in topics.items()]
        spin_until(self.executor, lambda: all(self.sim.count_subscribers(t) >= 1
                                              for t in topics), what='outputs matched')

    def tick(self, count=1):
        """Run the node's timer callback ``count`` times; receive what each tick sent."""
        for _ in range(count):
            expected = {topic: len(self.received[topic]) + 1 for topic in self._tick_topics()}
            self.sim.tick()
            spin_until(self.executor, lambda: all(len(self.received[topic]) >= count
                                                  for topic, count in expected.items()),
                       what='tick outputs received')

    def _tick_topics(self):
        """Topics the node's next tick publishes on."""
        settings = self.sim.settings
        topics = ['/clock'] if settings.publish_clock else []
        if self.sim.ticks % settings.publish_every == 0:
            topics += [self.topic('poses'), self.topic('markers')]
            topics += [self.topic(f'{body.name}/{kind}') for body in self.sim.scene.bodies
                       for kind in ('pose', 'twist', 'odom')]
        return topics

    def latest(self, topic):
        """Return the last message received on the node-relative ``topic`` (or absolute /name)."""
        return self.received[topic if topic.startswith('/') else self.topic(topic)][-1]

    def state(self, body):
        """Position (3,), orientation (4,), velocity (3,), angular velocity (3,), time.

        From the latest PoseStamped and TwistStamped of ``body`` (world axes).
        """
        pose, twist = self.latest(f'{body}/pose'), self.latest(f'{body}/twist')
        position, orientation = conversions.pose_arrays(pose.pose)
        return (position, orientation, conversions.vector_array(twist.twist.linear),
                conversions.vector_array(twist.twist.angular),
                conversions.to_seconds(pose.header.stamp))

    def send(self, body, topic, message):
        """Publish ``message`` on ``~/<body>/<topic>`` and wait until the node stored it.

        The first message on a topic waits until the node subscribes (set_pose and
        set_twist: once it has seen the publisher, within the node's DEMAND_REFRESH).
        """
        key = (body, topic)
        if key not in self._publishers:
            publisher = self.probe.create_publisher(type(message), self.topic(f'{body}/{topic}'),
                                                    10)
            spin_until(self.executor, lambda: publisher.get_subscription_count() >= 1,
                       what=f'{body}/{topic} matched')
            self._publishers[key] = publisher
        waiting = self.sim.pending_inputs
        self._publishers[key].publish(message)
        spin_until(self.executor, lambda: self.sim.pending_inputs > waiting,
                   what=f'{topic} received')

    def set_pose(self, body, position, orientation, frame_id='world'):
        """Send a PoseStamped on ``~/<body>/set_pose``."""
        message = PoseStamped()
        message.header.frame_id = frame_id
        pose = message.pose
        pose.position.x, pose.position.y, pose.position.z = (float(v) for v in position)
        q = pose.orientation
        q.x, q.y, q.z, q.w = (float(v) for v in orientation)
        self.send(body, 'set_pose', message)

    def set_twist(self, body, linear, angular, frame_id='world'):
        """Send a TwistStamped on ``~/<body>/set_twist`` (world axes)."""
        message = TwistStamped()
        message.header.frame_id = frame_id
        twist = message.twist
        twist.linear.x, twist.linear.y, twist.linear.z = (float(v) for v in linear)
        twist.angular.x, twist.angular.y, twist.angular.z = (float(v) for v in angular)
        self.send(body, 'set_twist', message)

    def push(self, body, frame_id, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)):
        """Publish a WrenchStamped on ``~/<body>/wrench`` and wait until the node holds it."""
        message = WrenchStamped()
        message.header.frame_id = frame_id
        wrench = message.wrench
        wrench.force.x, wrench.force.y, wrench.force.z = (float(f) for f in force)
        wrench.torque.x, wrench.torque.y, wrench.torque.z = (float(t) for t in torque)
        self.send(body, 'wrench', message)

    def call(self, service_type, name, request):
        """Call the node-relative service ``name`` from the probe and return the response."""
        client = self.probe.create_client(service_type, self.topic(name))
        spin_until(self.executor, client.service_is_ready, what=f'service {name}')
        future = client.call_async(request)
        spin_until(self.executor, future.done, what=f'{name} response')
        self.probe.destroy_client(client)
        return future.result()

    def set_parameters(self, **values):
        """Set the node's parameters as ``ros2 param set`` would; the SetParametersResults.

        A change that needs preparing (scene, integrator) is then swapped in or refused
        before this returns, as a waiting client would see it.
        """
        results = self.sim.set_parameters([Parameter(name, value=value)
                                           for name, value in values.items()])
        assert self.sim.reconfiguration.wait(PREPARATION_TIMEOUT), 'preparation timed out'
        return results

    def diagnostics(self):
        """Have the node publish /diagnostics now; return the received key -> text values."""
        count = len(self.received['/diagnostics'])
        self.sim.publish_diagnostics()
        spin_until(self.executor, lambda: len(self.received['/diagnostics']) > count,
                   what='diagnostics received')
        return conversions.diagnostic_values(self.received['/diagnostics'][-1])

    def destroy(self):
        for node in (self.sim, self.probe):
            self.executor.remove_node(node)
            node.destroy_node()
