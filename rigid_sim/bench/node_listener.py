# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The listener process of ``rigid_sim_bench node``: counts the messages on given topics.

``python -m rigid_sim.bench.node_listener TOPIC...``; a topic's last name (``pose``,
``twist``, ``odom``, ``poses``, ``clock``) names its type. Every line read on stdin is
answered with one JSON line on stdout, ``{topic: messages received so far}``. SIGINT ends it.

It runs in its own process so that the node under test, which only fills and sends outputs
that have subscribers, pays for publishing as it would to a real user, and so that receiving
does not take CPU time from the node's thread. Messages arrive serialised (``raw=True``):
counting needs no Python message objects, so the listener keeps up with what it is sent.
The EventsExecutor's ``spin_once`` keeps its callback rate whatever the number of
subscriptions, where the SingleThreadedExecutor's falls with every subscription
(docs/ros_notes.md).
"""
import json
import sys
import threading

import rclpy
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rosgraph_msgs.msg import Clock

TYPES = {'pose': PoseStamped, 'twist': TwistStamped, 'odom': Odometry, 'poses': PoseArray,
         'clock': Clock}
QUEUE_DEPTH = 10   # the node's; a listener that fell behind would lose messages, not queue


def message_type(topic):
    """Return the message class of ``topic``, from its last name."""
    return TYPES[topic.rsplit('/', 1)[-1]]


def answer_requests(counts):
    """Print ``counts`` as a JSON line for every line on stdin, until stdin closes."""
    for _ in sys.stdin:
        print(json.dumps(counts), flush=True)


def counter(counts, topic):
    """Return a subscription callback that adds one to ``counts[topic]``."""
    def count(_serialised):
        counts[topic] += 1
    return count


def main(topics):
    """Subscribe to ``topics`` and count what arrives until SIGINT."""
    rclpy.init()
    try:
        node = rclpy.create_node('rigid_sim_bench_listener')
        counts = dict.fromkeys(topics, 0)   # keys fixed here: the answering thread reads it
        for topic in topics:
            node.create_subscription(message_type(topic), topic, counter(counts, topic),
                                     QUEUE_DEPTH, raw=True)
        executor = EventsExecutor()   # spin() hangs in these wheels; spin_once works
        executor.add_node(node)
        threading.Thread(target=answer_requests, args=(counts,), daemon=True).start()
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()


if __name__ == '__main__':
    main(sys.argv[1:])
