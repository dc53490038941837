# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""qos_overrides.<topic>.publisher.<policy>: honoured by the publisher it names, or refused.

What a publisher offers is read from the ROS graph, as another node sees it.
"""
import pytest
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

from rigid_sim.node import RigidSimNode
from rigid_sim.parameters import ParameterError
from ros_harness import spin_until

SCENE = 'bodies:\n  - {name: box, shape: {type: box, size: [1, 1, 1]}, mass: 1.0}\n'


def start(context, write_scene, **overrides):
    parameters = [Parameter('scene', value=write_scene(SCENE))]
    parameters += [Parameter(f'qos_overrides.{name}', value=value)
                   for name, value in overrides.items()]
    return RigidSimNode(context=context, parameter_overrides=parameters)


def offered(node, topic):
    info, = node.get_publishers_info_by_topic(topic)
    return info.qos_profile


def depth(node, topic):
    """History depth of the node's publisher of ``topic`` (discovery does not carry it)."""
    publisher, = [p for p in node.publishers if p.topic_name == topic]
    return publisher.qos_profile.depth


def test_overrides_of_aggregate_and_per_body_topics_are_honoured(ros_context, write_scene):
    """Overrides of the QoS of aggregate and per-body topics hold, across a scene reload too.

    Best effort ~/poses, transient-local /clock and a depth-2 ~/box/pose; the declared
    parameters say what was applied.
    """
    node = start(ros_context, write_scene, **{
        '/rigid_sim/poses.publisher.reliability': 'best_effort',
        '/clock.publisher.durability': 'transient_local',
        '/rigid_sim/box/pose.publisher.depth': 2})
    assert offered(node, '/rigid_sim/poses').reliability == ReliabilityPolicy.BEST_EFFORT
    assert offered(node, '/clock').durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert offered(node, '/rigid_sim/box/pose').reliability == ReliabilityPolicy.RELIABLE
    assert node.get_parameter('qos_overrides./rigid_sim/box/pose.publisher.depth').value == 2
    assert (depth(node, '/rigid_sim/box/pose'), depth(node, '/rigid_sim/box/twist')) == (2, 10)
    reload = Parameter('scene', value=write_scene(SCENE, 'again.yaml'))
    assert node.set_parameters([reload])[0].successful
    assert depth(node, '/rigid_sim/box/pose') == 2
    node.destroy_node()


@pytest.mark.parametrize('name, value, reason', [
    ('/rigid_sim/nowhere.publisher.depth', 3, 'publishes no such topic'),
    ('/rigid_sim/box/wrench.subscription.depth', 3, 'publishers only'),
    ('/rigid_sim/poses.publisher.lifespan', 3, 'publishers only'),
])
def test_overrides_the_node_cannot_honour_are_refused_at_start(
        ros_context, write_scene, name, value, reason):
    with pytest.raises(ParameterError) as refused:
        start(ros_context, write_scene, **{name: value})
    assert reason in str(refused.value) and name in str(refused.value)


def test_subscriber_with_matching_qos_receives_from_an_overridden_publisher(
        harness, write_scene, ros_context):
    """A transient-local subscription to /clock that joins after the tick still gets it."""
    from rclpy.node import Node
    from rclpy.qos import QoSProfile
    from rosgraph_msgs.msg import Clock
    sim = harness(write_scene(SCENE), **{
        'qos_overrides./clock.publisher.durability': 'transient_local'})
    sim.tick(1)
    late = Node('late', context=ros_context)
    got = []
    late.create_subscription(Clock, '/clock', got.append,
                             QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    sim.executor.add_node(late)
    spin_until(sim.executor, lambda: got, what='the latched /clock')
    assert got[-1].clock.nanosec == 10_000_000
    sim.executor.remove_node(late)
    late.destroy_node()


def test_an_override_set_at_runtime_is_refused_as_read_at_start(harness, write_scene):
    """ros2 param set of a QoS override: refused saying when overrides are read.

    Through the node's parameter service, as the ros2 CLI calls it; the node runs on.
    """
    sim = harness(write_scene(SCENE))
    client = AsyncParameterClient(sim.probe, sim.sim.get_fully_qualified_name())
    spin_until(sim.executor, client.services_are_ready, what='parameter services')
    name = 'qos_overrides./rigid_sim/poses.publisher.depth'
    future = client.set_parameters([Parameter(name, value=5)])
    spin_until(sim.executor, future.done, what='set_parameters response')
    result, = future.result().results
    assert not result.successful
    assert result.reason == (f"['{name}']: QoS overrides are read at start only "
                             '(--params-file or -p); restart the node to change them')
    assert depth(sim.sim, '/rigid_sim/poses') == 10
    sim.tick(1)
