# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""qos_overrides.<topic>.publisher.<policy>: honoured by the publisher it names, or refused.

What a publisher offers is read from the ROS graph, as another node sees it.
"""
import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from rigid_sim.parameters import ParameterError

SCENE = 'bodies:\n  - {name: box, shape: {type: box, size: [1, 1, 1]}, mass: 1.0}\n'


def start(rigid_sim, **overrides):
    return rigid_sim(yaml=SCENE, **{f'qos_overrides.{name}': value
                                    for name, value in overrides.items()})


def offered(node, topic):
    info, = node.get_publishers_info_by_topic(topic)
    return info.qos_profile


def depth(node, topic):
    """History depth of the node's publisher of ``topic`` (discovery does not carry it)."""
    publisher, = [p for p in node.publishers if p.topic_name == topic]
    return publisher.qos_profile.depth


def test_overrides_of_aggregate_and_per_body_topics_are_honoured(rigid_sim, write_scene):
    """Overrides of the QoS of aggregate and per-body topics hold, across a scene reload too.

    Best effort ~/poses, transient-local /clock and a depth-2 ~/box/pose; the declared
    parameters say what was applied.
    """
    sim = start(rigid_sim, **{
        '/rigid_sim/poses.publisher.reliability': 'best_effort',
        '/clock.publisher.durability': 'transient_local',
        '/rigid_sim/box/pose.publisher.depth': 2})
    node = sim.node
    assert offered(node, '/rigid_sim/poses').reliability == ReliabilityPolicy.BEST_EFFORT
    assert offered(node, '/clock').durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert offered(node, '/rigid_sim/box/pose').reliability == ReliabilityPolicy.RELIABLE
    assert node.get_parameter('qos_overrides./rigid_sim/box/pose.publisher.depth').value == 2
    assert (depth(node, '/rigid_sim/box/pose'), depth(node, '/rigid_sim/box/twist')) == (2, 10)
    assert sim.set_parameters(scene=write_scene(SCENE, 'again.yaml'))[0].successful
    assert depth(node, '/rigid_sim/box/pose') == 2


@pytest.mark.parametrize('name, value, reason', [
    ('/rigid_sim/nowhere.publisher.depth', 3, 'publishes no such topic'),
    ('/rigid_sim/box/wrench.subscription.depth', 3, 'publishers only'),
    ('/rigid_sim/poses.publisher.lifespan', 3, 'publishers only'),
])
def test_overrides_the_node_cannot_honour_are_refused_at_start(rigid_sim, name, value, reason):
    with pytest.raises(ParameterError) as refused:
        start(rigid_sim, **{name: value})
    assert reason in str(refused.value) and name in str(refused.value)


def test_subscriber_with_matching_qos_receives_from_an_overridden_publisher(rigid_sim):
    """A transient-local subscription to /clock that joins after the tick still gets it."""
    sim = start(rigid_sim, **{'/clock.publisher.durability': 'transient_local'})
    sim.step(1)
    late = sim.create_node('late')
    got = []
    late.create_subscription(Clock, '/clock', got.append,
                             QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    sim.step(0)   # matches the late subscription, then delivers what is due to it
    assert got[-1].clock.nanosec == 10_000_000


def test_an_override_set_at_runtime_is_refused_as_read_at_start(rigid_sim):
    """ros2 param set of a QoS override: refused saying when overrides are read.

    Through the node's parameter service, as the ros2 CLI calls it; the node runs on.
    """
    sim = start(rigid_sim)
    name = 'qos_overrides./rigid_sim/poses.publisher.depth'
    value = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=5)
    answer = sim.call(SetParameters, 'set_parameters',
                      SetParameters.Request(parameters=[Parameter(name=name, value=value)]))
    result, = answer.results
    assert not result.successful
    assert result.reason == (f"['{name}']: QoS overrides are read at start only "
                             '(--params-file or -p); restart the node to change them')
    assert depth(sim.node, '/rigid_sim/poses') == 10
    sim.step(1)
