# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's body inputs: messages stored on arrival, applied to the world at the tick.

Subscription callbacks only store messages, so a callback never touches the world while
it steps; :meth:`BodyInputs.apply` is run by the tick, in arrival order. A refused message
changes nothing: it is counted per body, and the last reason is kept for /diagnostics.

Only the newest message per body, topic and frame_id since the last tick is applied: the
others are counted as superseded (a flood is held, not refused), so the work of a tick does
not grow with the message rate. A callback also takes whatever else is queued on its
subscription at once (at most ``DRAIN_LIMIT``), since the executor would spend a round of
its wait set on each message otherwise. At most ``MAX_PENDING`` distinct (body, topic,
frame_id) wait for one tick; more are refused.

Every subscription costs the executor time on each of its rounds, whether messages come or
not (docs/performance.md), so ``set_pose`` and ``set_twist``, which most runs never use,
are subscribed to only once a publisher on the topic appears in the graph: looked for
every ``DEMAND_REFRESH`` seconds of wall time.
"""
import math

from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from rclpy.clock import Clock, ClockType

from rigid_sim import bounded_input, conversions, on_demand
from rigid_sim.core.body_state import with_pose, with_twist
from rigid_sim.core.scene import wrench_target
from rigid_sim.core.text import shown
from rigid_sim.qos_overrides import QUEUE_DEPTH

WARNING_PERIOD = 2.0  # s of wall time between two warnings about refused inputs
DEMAND_REFRESH = 0.5  # s of wall time between two looks for new set_pose/set_twist publishers
STATE_TOPICS = (('set_pose', PoseStamped), ('set_twist', TwistStamped))
INPUT_KINDS = dict(STATE_TOPICS, wrench=WrenchStamped)   # topic -> message type
DRAIN_LIMIT = 100    # messages one callback takes from its queue (the queue holds 10)
MAX_PENDING = 1000   # distinct (body, topic, frame_id) waiting for one tick


def held_wrenches(world):
    """Return the world's held wrenches (``hold``, ``release``, ``check``): the only way in."""
    return world.inputs


class Refusals:
    """Refused input messages (a count per body, the last reason) and superseded ones.

    Counted since the node started: a scene edit or reload adds the new bodies' names and
    keeps every count, so /diagnostics never reports fewer refusals than it did.
    """

    def __init__(self, names):
        self.counts = {name: 0 for name in names}
        self.superseded = {name: 0 for name in names}
        self.last = ''

    def track(self, names):
        """Count for ``names`` too (the bodies of a new scene), keeping every count so far."""
        for name in names:
            self.counts.setdefault(name, 0)
            self.superseded.setdefault(name, 0)

    def add(self, name, topic, error, logger):
        """Count one refused message on ``~/<name>/<topic>`` and warn, throttled."""
        self.counts[name] += 1
        self.last = f'~/{name}/{topic}: {error}'
        logger.warning(f'refused a {topic} on {self.last}', throttle_duration_sec=WARNING_PERIOD)


def _world_axes(message, topic, world_frame):
    """Raise ValueError unless a set_pose/set_twist ``message`` is in ``world_frame``."""
    if message.header.frame_id != world_frame:
        raise ValueError(f'unknown frame_id {shown(message.header.frame_id)}: {topic} is given '
                         f'in the world frame; valid: [{world_frame!r}]')


class BodyInputs:
    """The input subscriptions of one scene and the messages received since the last tick.

    Parameters
    ----------
    node : rclpy.node.Node
        Creates and destroys the subscriptions; its logger warns about refusals.
    scene : rigid_sim.core.scene.Scene
    per_body_limit : int
        Up to this many bodies, the wrench topics are subscribed to at once; in a larger
        scene, as set_pose is, once a publisher appears.
    """

    def __init__(self, node, scene, per_body_limit):
        self._node = node
        self.per_body_limit = per_body_limit
        self._subscribed = {}      # (topic, body name) -> (subscription, [body index])
        self._awaited = {}         # resolved topic name -> (topic, body index), not subscribed
        # (topic, body index, frame_id) -> newest message since the last tick
        self._inbox = {}
        self.received = 0          # input messages taken since the node started
        self._names = []           # body names of the scene, in scene order
        self.refusals = Refusals(())
        self._appliers = {'wrench': self._hold, 'set_pose': self._set_pose,
                          'set_twist': self._set_twist}
        self.wire(scene)
        node.create_timer(DEMAND_REFRESH, self.subscribe_on_demand,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def plan(self, scene, per_body_limit):
        """Make what :meth:`wire` needs for ``scene`` without touching topics.

        Returns the bodies' names, the (index, name) of the wrench topics subscribed to at
        once and the resolved names of the awaited ones; a scene's swap has it made in the
        owner's worker, since resolving a name per body and topic grows with the bodies.
        """
        wrenched = [(index, body) for index, body in enumerate(scene.bodies)
                    if body.wrench_input]
        at_once = len(scene.bodies) <= per_body_limit
        awaited = [(index, body, topic) for index, body in enumerate(scene.bodies)
                   for topic, _ in STATE_TOPICS]
        awaited += [] if at_once else [(index, body, 'wrench') for index, body in wrenched]
        return ([body.name for body in scene.bodies],
                [(index, body.name) for index, body in wrenched if at_once],
                {self._node.resolve_topic_name(f'~/{body.name}/{topic}'): (topic, index)
                 for index, body, topic in awaited})

    def wire(self, scene, plan=None):
        """Subscribe to the wrench topic of every body of ``scene`` that takes wrenches.

        ``plan`` is what :meth:`plan` made for it (None: made now).
        """
        if plan is None:
            plan = self.plan(scene, self.per_body_limit)
        # A body kept by a scene edit keeps its subscriptions (re-pointed at its new index):
        # making and destroying every body's at each spawn held control 0.1-0.7 s.
        kept, self._subscribed = self._subscribed, {}
        self._names, subscribed, self._awaited = plan
        for index, name in subscribed:
            if ('wrench', name) in kept:
                self._keep(kept.pop(('wrench', name)), ('wrench', name), index)
            else:
                self._subscribe(WrenchStamped, 'wrench', index, name)
        for key, (subscription, at) in kept.items():
            awaited = self._awaited.pop(subscription.topic_name, None)
            if awaited is not None and awaited[0] == key[0]:
                self._keep((subscription, at), key, awaited[1])
            else:
                self._node.destroy_subscription(subscription)
        self.clear()
        self.refusals.track(self._names)

    def _keep(self, subscribed, key, index):
        subscribed[1][0] = index
        self._subscribed[key] = subscribed

    def _subscribe(self, kind, topic, index, name):
        made, at = [], [index]   # at: the body's index, moved when a scene edit moves it

        def take(message):
            self._store(topic, at[0], message)
            self._drain(made[0], topic, at[0])
        made.append(bounded_input.subscribe(self._node, kind, f'~/{name}/{topic}', take,
                                            QUEUE_DEPTH))
        self._subscribed[(topic, name)] = (made[0], at)
        return made[0]

    def _drain(self, subscription, topic, index):
        # rclpy's executor takes messages this way, one per round of its wait set.
        with subscription.handle:
            for _ in range(DRAIN_LIMIT):
                taken = subscription.handle.take_message(subscription.msg_type,
                                                         subscription.raw)
                if taken is None:
                    return
                self._store(topic, index, bounded_input.read(taken[0], subscription.msg_type))

    def _store(self, topic, index, message):
        self.received += 1
        if isinstance(message, bounded_input.Oversized):
            self.refusals.add(self._names[index], topic, message, self._node.get_logger())
            return
        key = (topic, index, message.header.frame_id)
        if self._inbox.pop(key, None) is not None:
            self.refusals.superseded[self._names[index]] += 1
        elif len(self._inbox) >= MAX_PENDING:
            self.refusals.add(self._names[index], topic, f'more than {MAX_PENDING} distinct '
                              'frame_ids wait for one tick', self._node.get_logger())
            return
        self._inbox[key] = message   # at the end: applied in the order of the newest

    def subscribe_on_demand(self):
        """Subscribe to every awaited input topic that has appeared in the graph."""
        if not self._awaited:
            return
        on_demand.make_appeared(self._node.topic_listing, self._awaited, self._subscribe_awaited)

    def _subscribe_awaited(self, name):
        topic, index = self._awaited.pop(name)
        self._subscribe(INPUT_KINDS[topic], topic, index, self._names[index])

    def topics(self):
        """Fully qualified names of every input topic, subscribed to or awaited."""
        return {subscription.topic_name for subscription, _ in self._subscribed.values()} | set(
            self._awaited)

    def clear(self):
        """Forget every message not applied yet."""
        self._inbox.clear()

    def apply(self, world, scene, settings):
        """Apply the newest stored messages in arrival order; a refused one changes nothing.

        Parameters
        ----------
        world : rigid_sim.core.world.World
            The world that holds the wrenches.
        scene : rigid_sim.core.scene.Scene
            The world's scene (frames and points).
        settings : rigid_sim.parameters.Settings
            ``world_frame`` and ``wrench_timeout`` are read.
        """
        inbox, self._inbox = self._inbox, {}
        for (topic, index, _), message in inbox.items():
            try:
                self._appliers[topic](world, scene.bodies[index], index, message, settings)
            except ValueError as error:
                self.refusals.add(scene.bodies[index].name, topic, error,
                                  self._node.get_logger())

    @staticmethod
    def _hold(world, body, index, message, settings):
        frame_id = message.header.frame_id
        prefix = settings.frame_prefix
        # The body and point frames carry the prefix in tf; a wrench may name them so.
        if prefix and frame_id != settings.world_frame and frame_id.startswith(prefix):
            frame_id = frame_id[len(prefix):]
        frame, point = wrench_target(body, frame_id, settings.world_frame)
        force, torque = conversions.wrench_arrays(message)
        timeout = settings.wrench_timeout
        expires = world.time + timeout if timeout > 0.0 else math.inf
        held_wrenches(world).hold(index, message.header.frame_id, frame, force, torque, point,
                                  expires)

    @staticmethod
    def _set_pose(world, body, index, message, settings):
        _world_axes(message, 'set_pose', settings.world_frame)
        origin, orientation = conversions.pose_arrays(message.pose)
        world.y = with_pose(world.bodies, world.y, index, origin, orientation)

    @staticmethod
    def _set_twist(world, body, index, message, settings):
        _world_axes(message, 'set_twist', settings.world_frame)
        twist = message.twist
        world.y = with_twist(world.bodies, world.y, index,
                             conversions.vector_array(twist.linear),
                             conversions.vector_array(twist.angular))
