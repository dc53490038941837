# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Input messages taken serialised, and read only when they are of an input's size.

A WrenchStamped, PoseStamped or TwistStamped the node can use is ~100 bytes serialised: its
only field of free length is ``header.frame_id``, a frame name of at most a few hundred
characters. But anyone on the graph may publish one whose frame_id holds hundreds of MB. So
the input subscriptions take the serialised bytes, whose length is known at once, and refuse
a message above MAX_INPUT_BYTES unread: no Python work on it, no copy of it kept until the
tick. The take itself still copies the message out of DDS holding the interpreter, ~2 ms a
MB (docs/performance.md, "Input messages of hundreds of MB"), which no rclpy call avoids.
"""
from rclpy.serialization import deserialize_message

# Bytes of a serialised input message, at most: a frame_id names at most a prefix, a body
# and a point, 100 characters each, so no message the node can use comes near it; reading
# one this long takes ~70 us (measured).
MAX_INPUT_BYTES = 65536


class Oversized(ValueError):
    """An input message refused unread: its serialised length is above MAX_INPUT_BYTES."""


def subscribe(node, kind, topic, callback, qos):
    """Subscribe ``callback(message)`` to ``topic``: each message taken as bytes, then read.

    ``callback`` gets the message, or an :class:`Oversized` error in its place.
    """
    return node.create_subscription(kind, topic, lambda data: callback(read(data, kind)),
                                    qos, raw=True)


def read(data, kind):
    """Return the ``kind`` message serialised in ``data``, or Oversized if it is too long."""
    if len(data) > MAX_INPUT_BYTES:
        return Oversized(f'a {kind.__name__} of {len(data)} bytes serialised, above the '
                         f'{MAX_INPUT_BYTES} an input message may have (its frame_id names a '
                         'frame of at most a few hundred characters); not read')
    return deserialize_message(data, kind)
