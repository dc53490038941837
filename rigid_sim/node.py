"""The rclpy node: parameters, a wall-clock timer, wrench inputs, state outputs, services.

The node holds no physics: a :class:`~rigid_sim.core.world.World` does. Subscription
callbacks only store messages; :meth:`RigidSimNode.tick`, run by the timer, applies them,
advances the world and publishes. Tests call ``tick()`` directly for deterministic steps.
"""
import math
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped, WrenchStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMessage
from std_srvs.srv import SetBool, Trigger
from visualization_msgs.msg import MarkerArray

from rigid_sim import conversions, parameters
from rigid_sim.core.integrators import make_integrator
from rigid_sim.core.scene import build_world, check_world_frame, load_scene, wrench_target
from rigid_sim.diagnostics_window import TickStats, health, refusal_values, window_values
from rigid_sim.resources import find_scene

NODE_NAME = 'rigid_sim'
DIAGNOSTICS_PERIOD = 1.0  # s of wall time; /diagnostics aggregators expect about 1 Hz
WARNING_PERIOD = 2.0      # s of wall time between two warnings about refused wrenches
# Outputs nobody subscribes to are neither filled nor sent. Who listens is asked again this
# often (s of wall time; ~1.5 us per topic): a new subscriber waits at most this long on top
# of discovery, which takes 0.3-0.7 s between processes anyway.
LISTENER_REFRESH = 0.5
QUEUE_DEPTH = 10
# Per-body publishers go without rclpy's default QoS event handlers (which only log an
# incompatible-QoS warning): each is a waitable the executor re-collects on every spin, and
# 3N of them cut the real-time factor at N = 1000 from 0.99 to under 0.1 (rigid_sim_bench
# node). The few aggregate publishers and the wrench subscriptions keep the warning.
NO_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)


def load(settings):
    """The scene named by ``settings`` and its world (SceneError, FileNotFoundError,
    ParameterError when ``world_frame`` is a frame of the scene)."""
    scene = load_scene(find_scene(settings.scene))
    check_frames(scene, settings)
    return scene, build_world(scene, settings.integrator, settings.tolerance)


def check_frames(scene, settings):
    """ParameterError unless ``settings.world_frame`` is distinct from the scene's frames."""
    try:
        check_world_frame(scene, settings.world_frame)
    except ValueError as error:
        raise parameters.ParameterError(f'world_frame: {error}') from None


class RigidSimNode(Node):
    """Simulates the rigid bodies of a scene file; see the package README for the contract.

    Parameters
    ----------
    **kwargs
        Passed to :class:`rclpy.node.Node` (``context``, ``cli_args``,
        ``parameter_overrides``, ...).

    Raises
    ------
    rigid_sim.parameters.ParameterError, rigid_sim.core.scene.SceneError, FileNotFoundError
        When a parameter value or the scene is refused at start.
    """

    def __init__(self, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        self.settings = parameters.declare(self)
        self.scene, self.world = load(self.settings)
        self.paused = False
        self.ticks = 0
        self._inbox = []           # (body index, WrenchStamped) in arrival order
        self._pending = None       # validated parameter change awaiting the post-set callback
        self._outputs = []         # per body: pose, twist and odometry publishers
        self._wrench_subscriptions = []
        self._clock_publisher = self.create_publisher(ClockMessage, '/clock', QUEUE_DEPTH)
        self._diagnostics_publisher = self.create_publisher(
            DiagnosticArray, '/diagnostics', QUEUE_DEPTH)
        self._pose_array_publisher = self.create_publisher(PoseArray, '~/poses', QUEUE_DEPTH)
        self._markers_publisher = self.create_publisher(MarkerArray, '~/markers', QUEUE_DEPTH)
        self._wire_scene()
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        wall_clock = Clock(clock_type=ClockType.STEADY_TIME)  # never sim time: we make it
        self.timer = self.create_timer(1.0 / self.settings.rate, self.tick, clock=wall_clock)
        self.create_timer(DIAGNOSTICS_PERIOD, self.publish_diagnostics, clock=wall_clock)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        self.get_logger().info(self._describe())
        self._warn_on_frame_mismatch()

    def _warn_on_frame_mismatch(self):
        # The parameter names the frame of every message; a scene naming another one is
        # most likely a mistake, so say which one is used rather than pick silently.
        if self.scene.world_frame != self.settings.world_frame:
            self.get_logger().warning(
                f'the scene names its fixed frame {self.scene.world_frame!r} but the '
                f'world_frame parameter is {self.settings.world_frame!r}: messages use '
                f'{self.settings.world_frame!r}; set world_frame:={self.scene.world_frame} '
                f'to follow the scene')

    def _describe(self):
        s = self.settings
        return (f'simulating {self.world.bodies.count} bodies from {self.scene.path} with '
                f'{s.integrator} at {s.rate:g} Hz, time_step {s.time_step:g} s x {s.substeps} '
                f'substeps (real-time factor {s.rate * s.time_step:g}); publishing every '
                f'{s.publish_every} ticks ({s.rate / s.publish_every:g} Hz); topics under '
                f'{self.get_fully_qualified_name()}/')

    def _wire_scene(self):
        """Per-body topics, reused output messages and counters for the current scene."""
        for publishers in self._outputs:
            for publisher in publishers:
                self.destroy_publisher(publisher)
        for subscription in self._wrench_subscriptions:
            self.destroy_subscription(subscription)
        self._outputs, self._wrench_subscriptions = [], []
        for index, body in enumerate(self.scene.bodies):
            topics = [(PoseStamped, 'pose'), (TwistStamped, 'twist'), (Odometry, 'odom')]
            self._outputs.append([self.create_publisher(kind, f'~/{body.name}/{topic}',
                                                        QUEUE_DEPTH, event_callbacks=NO_EVENTS)
                                  for kind, topic in topics])
            if body.wrench_input:
                self._wrench_subscriptions.append(self.create_subscription(
                    WrenchStamped, f'~/{body.name}/wrench',
                    lambda message, index=index: self._inbox.append((index, message)),
                    QUEUE_DEPTH))
        self._build_messages()
        self._listeners_due = -math.inf
        self._inbox.clear()
        self.refused = {body.name: 0 for body in self.scene.bodies}
        self._last_refusal = ''
        self._stats = TickStats(self.world.time)

    def _build_messages(self):
        self._messages = conversions.StateMessages(self.scene.bodies,
                                                   self.settings.world_frame)

    @property
    def pending_inputs(self):
        """Number of received wrench messages the next tick will apply."""
        return len(self._inbox)

    def tick(self):
        """Apply stored inputs, advance by ``time_step`` in ``substeps`` steps, publish."""
        started = time.perf_counter()
        self._apply_inputs()
        if not self.paused:
            self._advance()
        self._stats.add(time.perf_counter() - started)
        if self.settings.publish_clock:
            self._clock_publisher.publish(conversions.clock(self.world.time))
        if self.ticks % self.settings.publish_every == 0:
            self.publish_state()
        self.ticks += 1

    def _advance(self):
        """Integrate one tick; stop at a step the world gives up, keeping its last good state.

        The world never stores a non-finite value, so what is published stays finite; time
        does not advance past the failed step and the next tick tries again.
        """
        step = self.settings.time_step / self.settings.substeps
        for _ in range(self.settings.substeps):
            if not self.world.step(step):
                self._stats.failed_ticks += 1
                self.get_logger().error(
                    f'gave up a step at t = {self.world.time:g} s, state kept: '
                    f'{self.world.diagnostics.last_failure}',
                    throttle_duration_sec=WARNING_PERIOD)
                return

    def _apply_inputs(self):
        """Hold every stored wrench in arrival order; a refused one changes nothing."""
        inbox, self._inbox = self._inbox, []
        applied = self.world.inputs
        timeout = self.settings.wrench_timeout
        expires = self.world.time + timeout if timeout > 0.0 else math.inf
        for index, message in inbox:
            body = self.scene.bodies[index]
            name = body.name
            try:
                frame, point = wrench_target(body, message.header.frame_id,
                                             self.settings.world_frame)
                force, torque = conversions.wrench_arrays(message)
                applied.hold(index, message.header.frame_id, frame, force, torque, point,
                             expires)
            except ValueError as error:
                self.refused[name] += 1
                self._last_refusal = f'~/{name}/wrench: {error}'
                self.get_logger().warning(f'refused a wrench on {self._last_refusal}',
                                          throttle_duration_sec=WARNING_PERIOD)

    def publish_state(self):
        """Publish pose, twists and odometry of every body, the PoseArray and the markers.

        Only outputs with subscribers are filled and sent (see ``LISTENER_REFRESH``).
        """
        now = time.monotonic()
        if now >= self._listeners_due:
            self._listeners_due = now + LISTENER_REFRESH
            self._find_listeners()
        listened = self._listened_bodies
        if not (listened or self._aggregates):
            return
        # The PoseArray and the markers share every body's Pose; twists only where heard.
        posed = range(len(self._outputs)) if self._aggregates else listened
        self._messages.fill(self.world.snapshot(), posed, self._moving_bodies)
        for index in listened:
            outputs = (self._messages.poses[index], self._messages.twists[index],
                       self._messages.odometry[index])
            for publisher, wanted, message in zip(self._outputs[index], self._listened[index],
                                                  outputs):
                if wanted:
                    publisher.publish(message)
        for publisher in self._aggregates:
            publisher.publish(self._messages.pose_array if publisher is self._pose_array_publisher
                              else self._messages.markers)

    def _find_listeners(self):
        """Which outputs have subscribers: per body (pose, twist, odometry) and aggregates."""
        self._listened = [[publisher.get_subscription_count() > 0 for publisher in outputs]
                          for outputs in self._outputs]
        self._listened_bodies = [index for index, wanted in enumerate(self._listened)
                                 if any(wanted)]
        self._moving_bodies = [index for index, (_, twist, odometry) in enumerate(self._listened)
                               if twist or odometry]
        self._aggregates = [publisher for publisher in (self._pose_array_publisher,
                                                        self._markers_publisher)
                            if publisher.get_subscription_count() > 0]

    def publish_diagnostics(self):
        """Publish step time, real-time factor, energy, momenta and refused-input counts."""
        settings = self.settings
        values = {'simulated time [s]': self.world.time, 'paused': self.paused,
                  'integrator': settings.integrator,
                  **window_values(self._stats, self.world, settings.rate * settings.time_step),
                  **refusal_values(self.refused, self._last_refusal)}
        level, summary = health(self._stats, 1.0 / settings.rate)
        self._diagnostics_publisher.publish(conversions.diagnostics(
            f'{self.get_name()}: physics', self.world.time, level, summary, values))
        self._stats = TickStats(self.world.time)

    def _on_reset(self, request, response):
        self.world.reset()   # drops held wrenches too
        self._inbox.clear()
        self._stats = TickStats(self.world.time)
        response.success, response.message = True, 'back to the initial state at time 0'
        return response

    def _on_pause(self, request, response):
        self.paused = bool(request.data)
        response.success = True
        response.message = f'{"paused" if self.paused else "running"} at {self.world.time:g} s'
        return response

    def _on_set_parameters(self, changes):
        """Refuse a change with the reason, or keep it ready for :meth:`_apply_parameters`."""
        try:
            proposed = parameters.updated(self.settings, changes)
            names = {change.name for change in changes}
            self._pending = (proposed, self._prepare(proposed, 'scene' in names))
        except (ValueError, OSError) as error:  # SceneError is a ValueError
            return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _prepare(self, proposed, scene_set):
        """Load the scene (set again: reload the file), or build a changed integrator."""
        current = self.settings
        if scene_set:
            return load(proposed)
        check_frames(self.scene, proposed)
        if (proposed.integrator, proposed.tolerance) != (current.integrator, current.tolerance):
            return make_integrator(proposed.integrator, self.world, proposed.tolerance)
        return None

    def _apply_parameters(self, changes):
        proposed, prepared = self._pending
        previous, self.settings = self.settings, proposed
        if isinstance(prepared, tuple):
            self.scene, self.world = prepared
            self._wire_scene()  # new bodies: new topics, messages and counters
            # Setting the same file again reloads it too: say that time went back.
            self.get_logger().info(f'loaded {self.scene.path}: every body at its initial '
                                   'state, time 0, no wrench held')
        else:
            if prepared is not None:
                self.world.integrator = prepared
            if proposed.world_frame != previous.world_frame:
                self._build_messages()
        if proposed.rate != previous.rate:
            self.timer.timer_period_ns = 1e9 / proposed.rate
        self.get_logger().info(self._describe())
        self._warn_on_frame_mismatch()
