# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""/tf and /tf_static, where tf2_msgs is installed.

tf2_msgs comes with every ROS install but has no wheel for a pip-only machine, where
``rigid_sim_build_interfaces`` builds it into the venv; it is imported optionally: without it
the node logs once that tf is off, and how to add it, and publishes the same poses on its
other topics. The transforms themselves are geometry_msgs/TransformStamped,
built in :mod:`rigid_sim.conversions`; only their wrapping into a TFMessage, kept serialised
(:mod:`rigid_sim.serialized`), lives here.
"""
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from rigid_sim.interface_build import HOW_TO_ADD
from rigid_sim.serialized import SerializedPoses

try:
    from tf2_msgs.msg import TFMessage
except ImportError:
    TFMessage = None

# As tf2_ros's broadcasters: /tf keeps 100, /tf_static keeps its one latest message for
# listeners that join later (transient local).
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
STATIC_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)


class TfOutput:
    """The /tf and /tf_static publishers, or none and one log line without tf2_msgs.

    Parameters
    ----------
    node : rigid_sim.node.RigidSimNode
        Creates the publishers through its ``qos_overrides``.
    """

    def __init__(self, node):
        self.available = TFMessage is not None
        self.dynamic = self._static = None
        if not self.available:
            node.get_logger().info('tf2_msgs is not installed: /tf and /tf_static are off '
                                   f'(poses are on ~/poses and ~/<body>/pose); {HOW_TO_ADD}')
            return
        self.dynamic = node.qos_overrides.create_publisher(TFMessage, '/tf', TF_QOS)
        self._static = node.qos_overrides.create_publisher(TFMessage, '/tf_static', STATIC_QOS)

    def message(self, transforms, stamp):
        """Return /tf's message of ``transforms``, serialised, or None without tf.

        ``transforms`` is a list of TransformStamped whose headers all share ``stamp``
        (a Time): :class:`~rigid_sim.serialized.SerializedPoses` writes their poses.
        """
        return serialized_transforms(transforms, stamp) if self.available else None

    def publish_static(self, transforms):
        """Publish ``transforms`` as the node's one /tf_static message, replacing the last."""
        if self.available:
            self._static.publish(TFMessage(transforms=transforms))


def serialized_transforms(transforms, stamp):
    """Return the TFMessage of ``transforms`` kept serialised (their headers share ``stamp``)."""
    frames = [(t.transform.translation, t.transform.rotation) for t in transforms]
    return SerializedPoses(TFMessage(transforms=transforms), frames, stamp, len(transforms))
