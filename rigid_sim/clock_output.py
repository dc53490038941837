# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""/clock: the simulated time, sent at every tick while someone can receive it.

A publish costs the tick more than its physics at 100 Hz (docs/performance.md, "The
default scene's tick"), so with no subscriber it is skipped, and who listens is asked every
``LISTENER_REFRESH`` seconds, as for the state outputs. A transient-local publisher (set
with a QoS override) keeps its last message for subscribers that join later, so it sends at
every tick whether anyone listens or not.
"""
import math
import time

from rclpy.qos import DurabilityPolicy
from rosgraph_msgs.msg import Clock

from rigid_sim import conversions
from rigid_sim.outputs import LISTENER_REFRESH
from rigid_sim.qos_overrides import QUEUE_DEPTH


class ClockOutput:
    """The node's /clock publisher and the one message it refills (rclpy serialises at publish).

    Parameters
    ----------
    qos_overrides : rigid_sim.qos_overrides.QosOverrides
        Creates the publisher, honouring the overrides of /clock.
    """

    def __init__(self, qos_overrides):
        self._publisher = qos_overrides.create_publisher(Clock, '/clock', QUEUE_DEPTH)
        self._message = Clock()
        self._keeps_last = (self._publisher.qos_profile.durability
                            == DurabilityPolicy.TRANSIENT_LOCAL)
        self._heard = self._keeps_last
        self._listeners_due = -math.inf

    def refresh_listeners(self):
        """Ask who listens at the next publication (lockstep clients want every tick)."""
        self._listeners_due = -math.inf

    def publish(self, seconds):
        """Send simulated ``seconds`` if anyone can receive it."""
        if not self._keeps_last:
            now = time.monotonic()
            if now >= self._listeners_due:
                self._listeners_due = now + LISTENER_REFRESH
                self._heard = self._publisher.get_subscription_count() > 0
        if self._heard:
            conversions.to_time(seconds, self._message.clock)
            self._publisher.publish(self._message)
