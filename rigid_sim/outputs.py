# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's state outputs: per-body publishers, who listens to them, what they send.

Outputs nobody subscribes to are neither filled nor sent. Who listens is asked again every
``LISTENER_REFRESH`` seconds of wall time, not on every tick, because asking is a graph query
per topic, which at thousands of topics would cost more than the tick. A scene of more than
``per_body_limit`` bodies starts without per-body publishers (many thousands of them stall
start-up and the executor, see docs/ros_notes.md): each is made at such a refresh once a
subscriber to its topic appears in the graph; the PoseArray and the markers are always there.
"""
from collections import namedtuple
import math
import time

from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.event_handler import PublisherEventCallbacks
from visualization_msgs.msg import MarkerArray

from rigid_sim import conversions, on_demand
from rigid_sim.qos_overrides import QUEUE_DEPTH
from rigid_sim.tf_output import TfOutput

# A new subscriber waits at most this long (s of wall time) on top of discovery, which
# takes longer than this between processes anyway.
LISTENER_REFRESH = 0.5
# s of wall time to the next look while on-demand topics wait to be made (a slice each)
BACKLOG_LOOK = 0.05
# Per-body messages sent between two looks at the clock of a publication in slices
# (~20 us each, so ~2 ms).
BODIES_A_CHECK = 32
# Bodies whose topics' subscribers are counted in one look (~6 ms).
BODIES_A_LOOK = 500
# Per-body publishers go without rclpy's default QoS event handlers (which only log an
# incompatible-QoS warning): each is a waitable that the executor collects again on every
# spin, which with thousands of bodies costs more than the physics (docs/performance.md).
NO_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
BODY_TOPICS = ((PoseStamped, 'pose'), (TwistStamped, 'twist'), (Odometry, 'odom'))
# What StateOutputs.plan makes: the per-body topic names ('~/<body>/<topic>', per body in
# BODY_TOPICS order), resolved name -> (body, slot) of those made on demand (None: all at
# once) and the frame_messages.
OutputPlan = namedtuple('OutputPlan', 'names awaited frame')


class StateOutputs:
    """Pose, twist and odometry per body, the PoseArray, the markers, contacts, tf of a scene.

    Parameters
    ----------
    node : rigid_sim.node.RigidSimNode
        Creates (through its ``qos_overrides``) and destroys the publishers.
    scene : rigid_sim.core.scene.Scene
    world_frame : str
        frame_id of every published pose.
    frame_prefix : str
        Prefixed to every body and point frame.
    per_body_limit : int
        Up to this many bodies, every per-body publisher is made at once.
    """

    def __init__(self, node, scene, world_frame, frame_prefix, per_body_limit):
        self._node = node
        self.per_body_limit = per_body_limit
        self._awaited = {}           # resolved topic name -> (body index, slot), not made
        self._pose_array = node.qos_overrides.create_publisher(PoseArray, '~/poses',
                                                               QUEUE_DEPTH)
        self._markers = node.qos_overrides.create_publisher(MarkerArray, '~/markers',
                                                            QUEUE_DEPTH)
        # Contact points, normals and the ground, when the scene lists contact.
        self._contacts = node.qos_overrides.create_publisher(MarkerArray, '~/contacts',
                                                             QUEUE_DEPTH)
        self._contacts_heard = False
        self._world_frame = world_frame
        self._tf = TfOutput(node)
        self._bodies = []            # per body: its publishers, in BODY_TOPICS order
        self._names = []             # per body: its topics' names, in BODY_TOPICS order
        self._messages = None        # conversions.StateMessages of the scene
        self._tf_message = None      # SerializedPoses of /tf (None: no tf)
        self._listened = []          # per body: a bool per publisher
        self._listened_bodies = []   # indices of bodies with any subscriber
        self._moving = []            # per body: whether its twist or odometry is heard
        self._looked = 0             # bodies whose listeners the current round has looked at
        self._publishing = None      # (snapshot, bodies heard, how many sent) under way
        self._aggregates = []        # (publisher, message) of heard all-body outputs
        self._listeners_due = -math.inf
        self.wire(scene, world_frame, frame_prefix)

    def plan(self, scene, world_frame, frame_prefix, per_body_limit):
        """Make what :meth:`wire` needs that grows with the bodies, touching no topic.

        A scene's swap has it made in the owner's worker (per-body messages and resolved
        topic names take about 1 s for 5000 bodies), so that between two ticks only the at
        most ``per_body_limit`` publishers are made.
        """
        names = [[f'~/{body.name}/{topic}' for _, topic in BODY_TOPICS] for body in scene.bodies]
        awaited = None
        if len(scene.bodies) > per_body_limit:
            awaited = {self._node.resolve_topic_name(name): (index, slot)
                       for index, row in enumerate(names) for slot, name in enumerate(row)}
        return OutputPlan(names, awaited, self.frame_messages(scene, world_frame, frame_prefix))

    def wire(self, scene, world_frame, frame_prefix, plan=None):
        """Replace the per-body publishers and messages by those of ``scene``.

        ``plan`` is what :meth:`plan` made for it (None: made now). The markers of a
        previous scene are cleared in RViz (DELETEALL) first. Returns the replaced messages
        and publisher lists, for the caller to drop off the executor (freeing the messages
        of thousands of bodies takes as long as making them).
        """
        if plan is None:
            plan = self.plan(scene, world_frame, frame_prefix, self.per_body_limit)
        if self._messages is not None:
            self._markers.publish(conversions.delete_all_markers())
        # A body kept by a scene edit keeps its publishers: making and destroying every
        # body's at each spawn held control 0.1-0.7 s.
        kept = {name: publisher for names, publishers in zip(self._names, self._bodies)
                for name, publisher in zip(names, publishers) if publisher is not None}
        replaced, self._names = self._bodies, plan.names
        if plan.awaited is None:
            self._awaited = {}
            self._bodies = [[kept.pop(name) if name in kept else self._made(slot, name)
                             for slot, name in enumerate(row)] for row in plan.names]
        else:
            self._awaited = plan.awaited
            self._bodies = [[None] * len(BODY_TOPICS) for _ in plan.names]
            for name, publisher in list(kept.items()):
                index, slot = self._awaited.pop(publisher.topic_name, (None, None))
                if index is not None:
                    self._bodies[index][slot] = kept.pop(name)
        for publisher in kept.values():
            self._node.destroy_publisher(publisher)
        return replaced, self.set_frame(scene, world_frame, frame_prefix, plan.frame)

    def _made(self, slot, name):
        return self._node.qos_overrides.create_publisher(BODY_TOPICS[slot][0], name,
                                                         QUEUE_DEPTH, event_callbacks=NO_EVENTS)

    def _make_on_demand(self):
        """Make the awaited per-body publishers whose topic has appeared, a slice's worth.

        With more left, the next look is a BACKLOG_LOOK away, not a LISTENER_REFRESH.
        """
        if not on_demand.make_appeared(self._node.topic_listing, self._awaited,
                                       self._make_awaited):
            self._listeners_due = time.monotonic() + BACKLOG_LOOK

    def _make_awaited(self, name):
        index, slot = self._awaited.pop(name)
        self._bodies[index][slot] = self._made(slot, name)

    def frame_messages(self, scene, world_frame, frame_prefix):
        """Make the reused messages of ``scene`` with these frame names (:meth:`set_frame`)."""
        messages = conversions.StateMessages(scene.bodies, world_frame, frame_prefix)
        return (messages, self._tf.message(messages.transforms, messages.stamp),
                conversions.static_transforms(scene.bodies, frame_prefix, 0.0))

    def set_frame(self, scene, world_frame, frame_prefix, made=None):
        """Use the reused messages of ``scene`` for new frame names; resend tf_static.

        ``made`` is what :meth:`frame_messages` made for them (None: made now). Returns the
        replaced messages.
        """
        if made is None:
            made = self.frame_messages(scene, world_frame, frame_prefix)
        replaced = self._messages, self._tf_message
        self._messages, self._tf_message, static = made
        self._world_frame = world_frame
        self._tf.publish_static(static)
        self._listeners_due = -math.inf
        self._publishing = None   # its bodies and messages are gone
        self._listened = []
        return replaced

    @property
    def tf_available(self):
        """Whether /tf and /tf_static are published (tf2_msgs is installed)."""
        return self._tf.available

    def refresh_listeners(self):
        """Ask who listens at the next publication (lockstep clients want every tick)."""
        self._listeners_due = -math.inf

    def publish(self, world, until=None):
        """Fill and send every output of ``world``'s current state that has subscribers.

        Whether the publication is done: one to many per-body topics stops at ``until`` (a
        ``time.perf_counter`` deadline; None: no limit), after at least BODIES_A_CHECK bodies,
        and the next call goes on with it from the same snapshot, so the executor answers
        control between (3000 bodies' pose, twist and odometry took ~0.2 s).
        """
        if self._publishing is None:
            self._publishing = self._begin(world)
        snapshot, listened, done = self._publishing
        messages, moving = self._messages, self._moving
        while done < len(listened):
            chunk = listened[done:done + BODIES_A_CHECK]
            messages.fill(snapshot, chunk, [index for index in chunk if moving[index]])
            for index in chunk:
                sent = (messages.poses[index], messages.twists[index], messages.odometry[index])
                for publisher, wanted, message in zip(self._bodies[index],
                                                      self._listened[index], sent):
                    if wanted:
                        publisher.publish(message)
            done += len(chunk)
            if until is not None and done < len(listened) and time.perf_counter() >= until:
                self._publishing = snapshot, listened, done
                return False
        self._publishing = None
        return True

    def _begin(self, world):
        """Start a publication: contacts and every body's messages now, per-body ones to come.

        Returns (snapshot, bodies heard, 0) for :meth:`publish` to go on with.
        """
        now = time.monotonic()
        if now >= self._listeners_due:
            self._listeners_due = now + LISTENER_REFRESH
            self._find_listeners()
        if self._contacts_heard and world.contact is not None:
            _, points, normals, _ = world.contact.contacts()
            self._contacts.publish(conversions.contact_markers(
                self._world_frame, world.time, world.contact.parameters.planes, points,
                normals))
        if not (self._listened_bodies or self._aggregates):
            return None, [], 0
        snapshot = world.snapshot()
        conversions.to_time(snapshot.time, self._messages.stamp)
        for publisher, serialized in self._aggregates:   # every body's pose, as bytes
            serialized.write(snapshot.frames, self._messages.stamp)
            serialized.publish(publisher)
        return snapshot, self._listened_bodies, 0

    def _find_listeners(self):
        """Which outputs have subscribers: per body (pose, twist, odometry) and aggregates.

        The per-body ones of at most BODIES_A_LOOK bodies a look (a graph query per topic,
        ~4 us: 3000 bodies' took 35 ms); with more left, the next look is a BACKLOG_LOOK
        away and goes on from there.
        """
        if self._awaited:
            self._make_on_demand()
        if len(self._listened) != len(self._bodies):   # a scene of other bodies
            self._listened = [[False] * len(BODY_TOPICS) for _ in self._bodies]
            self._moving, self._looked = [False] * len(self._bodies), 0
        start = self._looked
        self._looked = min(len(self._bodies), start + BODIES_A_LOOK)
        for index in range(start, self._looked):
            heard = [publisher is not None and publisher.get_subscription_count() > 0
                     for publisher in self._bodies[index]]
            self._listened[index], self._moving[index] = heard, heard[1] or heard[2]
        if self._looked < len(self._bodies):
            self._listeners_due = min(self._listeners_due, time.monotonic() + BACKLOG_LOOK)
        else:
            self._looked = 0
        self._listened_bodies = [index for index, wanted in enumerate(self._listened)
                                 if any(wanted)]
        messages = self._messages
        aggregates = [(self._pose_array, messages.serialized_poses),
                      (self._markers, messages.serialized_markers)]
        if self._tf.available:
            aggregates.append((self._tf.dynamic, self._tf_message))
        self._aggregates = [(publisher, message) for publisher, message in aggregates
                            if publisher.get_subscription_count() > 0]
        self._contacts_heard = self._contacts.get_subscription_count() > 0
