# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The rclpy node: wires parameters, the tick, inputs, outputs and services together.

The node holds no physics: a :class:`~rigid_sim.core.world.World` does. Each job has its
own part: :mod:`rigid_sim.inputs` stores and applies messages, :mod:`rigid_sim.outputs`
publishes the state, :mod:`rigid_sim.control` serves pause and reset,
:mod:`rigid_sim.tick_loop` makes the node tick and :mod:`rigid_sim.diagnostics_output`
reports its health. :meth:`RigidSimNode.tick` applies the stored inputs, advances the
world and publishes; tests call it directly for deterministic steps.
"""
import time
from collections import namedtuple

from rclpy.node import Node

from rigid_sim import on_demand, parameters, sim_interfaces
from rigid_sim.clock_output import ClockOutput
from rigid_sim.control import SimControl
from rigid_sim.core.compile_cache import caching_note
from rigid_sim.core.imu import scene_imus
from rigid_sim.core.integrators import make_integrator
from rigid_sim.core.scene import build_world, check_world_frame, load_scene
from rigid_sim.core.warm_up import warm_up_reporting
from rigid_sim.diagnostics_output import DiagnosticsOutput
from rigid_sim.goal_input import GoalInput
from rigid_sim.imu_output import ImuOutputs
from rigid_sim.inputs import WARNING_PERIOD, BodyInputs
from rigid_sim.outputs import LISTENER_REFRESH, StateOutputs
from rigid_sim.qos_overrides import QosOverrides
from rigid_sim.reconfiguration import Reconfiguration
from rigid_sim.resources import allowed_roots, find_scene
from rigid_sim.tick_loop import TickLoop
from rigid_sim.world_owner import WorldOwner

__all__ = ['LISTENER_REFRESH', 'NODE_NAME', 'RigidSimNode']
NODE_NAME = 'rigid_sim'


def load(settings):
    """Load the scene named by ``settings`` and build its world.

    Raises SceneError, FileNotFoundError, or ParameterError when ``world_frame`` is a frame of
    the scene.
    """
    scene = load_scene(find_scene(settings.scene, settings.resource_paths),
                       allowed_roots(settings.resource_paths), **settings.resource_limits)
    check_frames(scene, settings)
    return scene, build_world(scene, settings.integrator, settings.tolerance,
                              settings.error_control)


def warm_up(world, name, logger, integrator=None, imus=None):
    """Compile or load ``world``'s kernels, logging what compiles and why; the count.

    Nothing is logged when every kernel is in memory or numba's disk cache; otherwise a line
    before the first compilation, one every ``PROGRESS_PERIOD`` seconds while it goes on,
    and the seconds it took after. At start this runs before the node creates its topics
    and services, so a client that finds one is answered without a compile's delay; after
    a runtime change it runs in the reconfiguration's worker while the old scene ticks on.

    Parameters
    ----------
    world : rigid_sim.core.world.World
        The world about to be stepped; left as it was.
    name : str
        The integrator's name, for the log lines.
    logger : rclpy.impl.rcutils_logger.RcutilsLogger
        Where the lines go (info level).
    integrator : rigid_sim.core.integrators.base.Integrator or None
        The method to compile for, when not the world's own.
    imus : rigid_sim.core.imu.Imus or None
        The world's IMUs, whose readings are compiled too.

    Returns
    -------
    int
        Kernel specialisations compiled (0: all were loaded or already compiled).
    """
    effects = ', '.join(type(effect).__name__.lower() for effect in world.effects) or 'none'
    readings = ' and its IMU readings' if imus is not None else ''
    seconds, compiled = warm_up_reporting(
        world, lambda: logger.info(
            f'compiling the {name} kernels for {world.bodies.count} bodies with effects '
            f'[{effects}]{readings}, not found in the kernel cache ({caching_note()}) ...'),
        lambda count, elapsed: logger.info(
            f'... still compiling: {count} kernels in {elapsed:.0f} s'),
        integrator, imus)
    if compiled:
        logger.info(f'compiled {compiled} kernels in {seconds:.1f} s')
    return compiled


# What a job made for the running scene: an integrator (an integrator or tolerance change)
# and the frame messages (StateOutputs.frame_messages, a change of frame names), or None.
Retuned = namedtuple('Retuned', 'integrator frame')


class TickInProgress:
    """The steps of one tick still to take, for the world it began on, then its publication."""

    def __init__(self, world, steps):
        self.world = world
        self.time = world.time   # where the last step ended: a reset or a new state stops it
        self.left = steps
        self.busy = 0.0          # s of wall time the tick has taken so far
        self.slices = 0          # times it returned to the loop before its end
        self.stepped = False     # its steps are all taken, counted, and /clock and IMUs sent


def check_frames(scene, settings):
    """Raise ParameterError unless ``settings.world_frame`` is distinct from the scene's frames."""
    try:
        check_world_frame(scene, settings.world_frame)
    except ValueError as error:
        raise parameters.ParameterError(f'world_frame: {error}') from None


class RigidSimNode(Node):
    """Simulates the rigid bodies of a scene file; see the package README for the contract.

    Parameters
    ----------
    start : optional
        Told ``start.exists(node)`` as soon as the node exists in the middleware, before the
        scene is loaded, and ``start.compiled()`` once its kernels are ready, before its
        topics and services are made (the executable's stop signal, :mod:`rigid_sim.main`).
    **kwargs
        Passed to :class:`rclpy.node.Node` (``context``, ``cli_args``,
        ``parameter_overrides``, ...).

    Raises
    ------
    rigid_sim.parameters.ParameterError, rigid_sim.core.scene.SceneError, FileNotFoundError
        When a parameter value or the scene is refused at start.
    """

    def __init__(self, start=None, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        if start is not None:
            start.exists(self)
        self.settings = parameters.declare(self)
        self.scene, self.world = load(self.settings)
        self.get_logger().info(self._describe(self.settings.start_paused))
        self._warn_on_frame_mismatch()
        # Before any topic or service exists: once a client discovers one, the node answers.
        self.compiled = warm_up(self.world, self.settings.integrator, self.get_logger(),
                                imus=scene_imus(self.scene, self.world))
        if start is not None:
            start.compiled()
        self.ticks = 0
        self._ticking = None   # the TickInProgress the loop left part-done, if any
        self.qos_overrides = QosOverrides(self)
        self.clock = ClockOutput(self.qos_overrides)
        self.topic_listing = on_demand.TopicListing(self)   # shared by the on-demand topics
        self.outputs = StateOutputs(self, self.scene, self.settings.world_frame,
                                    self.settings.frame_prefix,
                                    self.settings.per_body_topics_limit)
        self.imu_outputs = ImuOutputs(self, self.scene, self.world, self.settings.frame_prefix)
        self.inputs = BodyInputs(self, self.scene, self.settings.per_body_topics_limit)
        self.goals = GoalInput(self, self.scene, self.world)
        self.loop = TickLoop(self, self._tick, self.settings.rate)
        self.control = SimControl(self, self.settings.start_paused, self.loop,
                                  reset=self.reset, step_ticks=lambda: self.settings.step_ticks,
                                  now=lambda: self.world.time)
        self.control.before_step = self.refresh_listeners
        self.loop.set_paused(self.control.paused)
        self.health = DiagnosticsOutput(self, self.publish_diagnostics, self.world.time)
        self.qos_overrides.finish_start()
        self.owner = WorldOwner(self)   # the only one that replaces scene, world, settings
        self.reconfiguration = Reconfiguration(self)
        self._warn_on_slow_ticks_for_imus()
        self.sim_interfaces = sim_interfaces.serve(self)   # None without the package

    def destroy_node(self):
        """Destroy the node and its action server, which rclpy's ``destroy_node`` leaves.

        A live action server keeps the node, and with it the process's DDS participant, in
        the middleware after the node is destroyed (docs/ros_notes.md, "Shutdown"). The
        threads that solve goals and send big answers end too: an embedding process (a
        test suite) makes nodes by the hundred.
        """
        for waitable in list(self.waitables):
            waitable.destroy()
        if getattr(self, 'goals', None) is not None:
            self.goals.close()
        if getattr(self, 'sim_interfaces', None) is not None:
            self.sim_interfaces.entities.close()
        super().destroy_node()

    @property
    def paused(self):
        """Return whether integration is paused."""
        return self.control.paused

    def _warn_on_slow_ticks_for_imus(self):
        # An IMU reads at most once per tick: say so rather than read slower silently.
        imus = self.imu_outputs.imus
        tick_rate = 1.0 / self.settings.time_step
        for index, spec in zip(imus.bodies, imus.specs) if imus is not None else ():
            if spec.rate is not None and spec.rate > tick_rate * (1.0 + 1e-9):
                self.get_logger().warning(
                    f'the IMU of {self.scene.bodies[index].name!r} asks for {spec.rate:g} Hz '
                    f'but a tick advances {self.settings.time_step:g} s: it reads once per '
                    f'tick, {tick_rate:g} Hz of simulated time')

    def _warn_on_frame_mismatch(self):
        # The parameter names the frame of every message; a scene naming another one is
        # most likely a mistake, so say which one is used rather than pick silently.
        if self.scene.world_frame != self.settings.world_frame:
            self.get_logger().warning(
                f'the scene names its fixed frame {self.scene.world_frame!r} but the '
                f'world_frame parameter is {self.settings.world_frame!r}: messages use '
                f'{self.settings.world_frame!r}; set world_frame:={self.scene.world_frame} '
                f'to follow the scene')

    def _describe(self, paused):
        s = self.settings
        pace = (f'at {s.rate:g} Hz' if s.rate > 0.0 else 'as fast as possible (rate 0)')
        aim = (f'real-time factor {s.real_time_factor:g}' if s.rate > 0.0
               else 'no real-time factor')
        paused = ', paused' if paused else ''
        return (f'simulating {self.world.bodies.count} bodies from {self.scene.path} with '
                f'{s.integrator} {pace}, time_step {s.time_step:g} s x {s.substeps} '
                f'substeps ({aim}); publishing every {s.publish_every} ticks; topics under '
                f'{self.get_fully_qualified_name()}/{paused}')

    def tick(self):
        """Apply stored inputs, advance by ``time_step`` in ``substeps`` steps, publish.

        While paused, the inputs are applied and the outputs published, at the same time.
        A tick the loop left part-done is finished first, and is then this tick.
        """
        self._tick(advance=not self.paused)

    def _tick(self, advance, until=None):
        """Run one tick, or what is left of the one in progress; whether it is done.

        ``until`` (a ``time.perf_counter`` deadline; None: no limit) ends the tick's steps
        early, after at least one, and its publication to many per-body topics: the loop
        runs the rest in its next executor rounds, with control answered between them
        (docs/design.md, "Control apart from the work").
        ``advance`` is read when a tick starts only.
        """
        started = time.perf_counter()
        if self._ticking is None:
            self.inputs.apply(self.world, self.scene, self.settings)
            self.goals.apply(self.world, self.scene, self.settings)
            self._ticking = TickInProgress(self.world, self.settings.substeps if advance else 0)
        ticking = self._ticking
        ticking.busy += time.perf_counter() - started
        if not self._advance(ticking, until):
            return False
        if not ticking.stepped:
            ticking.stepped = True
            self.health.stats.add(ticking.busy)
            if self.settings.publish_clock:
                self.clock.publish(self.world.time)
            self.imu_outputs.publish(self.world)
        if self.ticks % self.settings.publish_every == 0 and not self.outputs.publish(
                self.world, until):
            ticking.slices += 1
            return False
        self._ticking = None
        self.ticks += 1
        return True

    def _advance(self, ticking, until=None):
        """Take the steps left of ``ticking``; whether the tick's steps are all done.

        Steps stop at ``until`` (after at least one), and at a step the world gives up,
        keeping its last good state: the world never stores a non-finite value, so what is
        published stays finite; time does not advance past the failed step and the next
        tick tries again. A tick whose world was replaced or reset since it began has its
        remaining steps dropped: they were meant for a world that is gone.
        """
        started = time.perf_counter()
        step = self.settings.time_step / self.settings.substeps
        try:
            while ticking.left > 0:
                if ticking.world is not self.world or ticking.time != self.world.time:
                    return True
                stepped = self.world.step(step)
                self.health.stats.note_error(self.world.diagnostics.error_estimate)
                ticking.left -= 1
                ticking.time = self.world.time
                if not stepped:
                    self.health.stats.failed_ticks += 1
                    self.get_logger().error(
                        f'gave up a step at t = {self.world.time:g} s, state kept: '
                        f'{self.world.diagnostics.last_failure}',
                        throttle_duration_sec=WARNING_PERIOD)
                    return True
                if until is not None and ticking.left > 0 and time.perf_counter() >= until:
                    ticking.slices += 1
                    return False
            return True
        finally:
            ticking.busy += time.perf_counter() - started

    def refresh_listeners(self):
        """Ask who listens to /clock and the state outputs at their next publication."""
        self.clock.refresh_listeners()
        self.outputs.refresh_listeners()

    def publish_diagnostics(self):
        """Publish step time, real-time factor, energy, momenta and refused-input counts."""
        extra = {'last refused change': self.reconfiguration.last_refusal or 'none',
                 'preparing a change': self.reconfiguration.preparing}
        self.health.publish(self.world, self.settings, self.paused, self.inputs.refusals,
                            self.loop.take_dropped(), self.loop.since_last_tick(), extra)

    def reset(self):
        """Back to the scene's initial state at time 0, dropping held and stored inputs."""
        self.world.reset()   # drops held wrenches too
        self.inputs.clear()
        self.imu_outputs.restart()
        self.health.restart(self.world.time)

    def check_frames(self, settings):
        """Raise ParameterError if ``settings.world_frame`` is a frame of the running scene."""
        check_frames(self.scene, settings)

    def prepare(self, settings, scene_changed):
        """Build what ``settings`` need and compile its kernels (in the owner's worker).

        Returns a new (scene, world, wiring) when ``scene_changed``, else a :class:`Retuned`
        for the running world and scene, which stay the running ones while the job runs (the
        owner's jobs run one at a time and only they replace them). Nothing the node runs is
        changed.
        """
        if scene_changed:
            scene, world = load(settings)
            warm_up(world, settings.integrator, self.get_logger(),
                    imus=scene_imus(scene, world))
            return scene, world, self.plan_wiring(scene, settings)
        running, integrator, frame = self.settings, None, None
        if (settings.integrator, settings.tolerance) != (running.integrator, running.tolerance):
            integrator = make_integrator(settings.integrator, self.world, settings.tolerance)
            warm_up(self.world, settings.integrator, self.get_logger(), integrator)
        frames = settings.world_frame, settings.frame_prefix
        if frames != (running.world_frame, running.frame_prefix):
            frame = self.outputs.frame_messages(self.scene, *frames)
        return Retuned(integrator, frame)

    def swap(self, settings, prepared):
        """Run what :meth:`prepare` made for ``settings``, between two ticks (by the owner)."""
        if isinstance(prepared, Retuned):
            self.owner.swap(settings, integrator=prepared.integrator, frame=prepared.frame)
        else:
            scene, world, wiring = prepared
            self.owner.swap(settings, scene, world, wiring=wiring)
            # Setting the same file again reloads it too: say that time went back.
            self.get_logger().info(f'loaded {self.scene.path}: every body at its initial '
                                   'state, time 0, no wrench held')

    def apply(self, previous, frame=None, rewired=False):
        """Act on the change of the settings from ``previous`` to the running ones.

        ``frame``: the messages of new frame names, made beside (None: made here), unless
        the scene was ``rewired`` with them. Returns the messages replaced, if any, for the
        caller to free beside (freeing 10 000 bodies' takes as long as making them).
        """
        settings = self.settings
        self.world.control.tolerance = settings.tolerance
        self.world.control.error_control = settings.error_control
        frames = (settings.world_frame, settings.frame_prefix)
        replaced = None
        if frames != (previous.world_frame, previous.frame_prefix) and not rewired:
            replaced = self.outputs.set_frame(self.scene, *frames, frame)
            self.imu_outputs.set_frame_prefix(settings.frame_prefix)
        if settings.rate != previous.rate:
            self.loop.set_rate(settings.rate)
        if settings != previous:
            self.get_logger().info(self._describe(self.paused))
            self._warn_on_frame_mismatch()
            self._warn_on_slow_ticks_for_imus()
        return replaced

    def plan_wiring(self, scene, settings):
        """Make what wiring ``scene`` takes that grows with its bodies: names, messages.

        Made in the owner's worker, beside the scene's world, so that the swap between two
        ticks only makes and destroys topics (docs/design.md, "One owner of the World").
        """
        return (self.outputs.plan(scene, settings.world_frame, settings.frame_prefix,
                                  settings.per_body_topics_limit),
                self.inputs.plan(scene, settings.per_body_topics_limit),
                self.goals.plan(scene))

    def wire_scene(self, wiring):
        """Wire the running scene: new topics, messages, counters and diagnostics window.

        ``wiring`` is what :meth:`plan_wiring` made for it with the running settings. Called
        by the owner's :meth:`~rigid_sim.world_owner.WorldOwner.swap` only; returns what the
        outputs replaced, for it to drop off the executor.
        """
        outputs, inputs, goals = wiring
        self.outputs.per_body_limit = self.inputs.per_body_limit = \
            self.settings.per_body_topics_limit
        replaced = self.outputs.wire(self.scene, self.settings.world_frame,
                                     self.settings.frame_prefix, outputs)
        self.imu_outputs.wire(self.scene, self.world, self.settings.frame_prefix)
        self.inputs.wire(self.scene, inputs)
        self.goals.wire(self.scene, self.world, goals)
        self.health.restart(self.world.time)
        return replaced
