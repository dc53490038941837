# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's body inputs: messages stored on arrival, applied to the world at the tick.

Subscription callbacks only store messages, so a callback never touches the world while
it steps; :meth:`BodyInputs.apply` is run by the tick. A refused message changes nothing:
it is counted per body, and the last reason is kept for /diagnostics.
"""
import math

from geometry_msgs.msg import WrenchStamped

from rigid_sim import conversions
from rigid_sim.core.effects.applied_wrench import AppliedWrenches
from rigid_sim.core.scene import wrench_target

QUEUE_DEPTH = 10
WARNING_PERIOD = 2.0  # s of wall time between two warnings about refused inputs


def held_wrenches(world):
    """Return the world's held wrenches (``hold``, ``release``, ``check``): the only way in."""
    return world.effect(AppliedWrenches)


class Refusals:
    """Refused input messages: a count per body and the last reason."""

    def __init__(self, names):
        self.counts = {name: 0 for name in names}
        self.last = ''

    def add(self, name, topic, error, logger):
        """Count one refused message on ``~/<name>/<topic>`` and warn, throttled."""
        self.counts[name] += 1
        self.last = f'~/{name}/{topic}: {error}'
        logger.warning(f'refused a {topic} on {self.last}', throttle_duration_sec=WARNING_PERIOD)


class BodyInputs:
    """The wrench subscriptions of one scene and the messages received since the last tick.

    Parameters
    ----------
    node : rclpy.node.Node
        Creates and destroys the subscriptions; its logger warns about refusals.
    scene : rigid_sim.core.scene.Scene
    """

    def __init__(self, node, scene):
        self._node = node
        self._subscriptions = []
        self._inbox = []           # (body index, WrenchStamped) in arrival order
        self.refusals = Refusals(())
        self.wire(scene)

    def wire(self, scene):
        """Subscribe to the wrench topic of every body of ``scene`` that takes wrenches."""
        for subscription in self._subscriptions:
            self._node.destroy_subscription(subscription)
        self._subscriptions = [
            self._node.create_subscription(
                WrenchStamped, f'~/{body.name}/wrench',
                lambda message, index=index: self._inbox.append((index, message)), QUEUE_DEPTH)
            for index, body in enumerate(scene.bodies) if body.wrench_input]
        self._inbox.clear()
        self.refusals = Refusals(body.name for body in scene.bodies)

    @property
    def pending(self):
        """Return the number of received messages the next tick will apply."""
        return len(self._inbox)

    def clear(self):
        """Forget every message not applied yet."""
        self._inbox.clear()

    def apply(self, world, scene, settings):
        """Hold every stored wrench in arrival order; a refused one changes nothing.

        Parameters
        ----------
        world : rigid_sim.core.world.World
            The world that holds the wrenches.
        scene : rigid_sim.core.scene.Scene
            The world's scene (frames and points).
        settings : rigid_sim.parameters.Settings
            ``world_frame`` and ``wrench_timeout`` are read.
        """
        inbox, self._inbox = self._inbox, []
        if not inbox:
            return
        held = held_wrenches(world)
        timeout = settings.wrench_timeout
        expires = world.time + timeout if timeout > 0.0 else math.inf
        for index, message in inbox:
            body = scene.bodies[index]
            try:
                frame, point = wrench_target(body, message.header.frame_id,
                                             settings.world_frame)
                force, torque = conversions.wrench_arrays(message)
                held.hold(index, message.header.frame_id, frame, force, torque, point, expires)
            except ValueError as error:
                self.refusals.add(body.name, 'wrench', error, self._node.get_logger())
