# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Parameter changes at runtime: checked at once, prepared beside the running scene, swapped.

A change of ``scene``, ``integrator`` or ``tolerance`` needs work that may take seconds (a
scene's meshes and inertias, compiling kernels that are not cached). The parameter call
checks what it can at once (types, ranges, that the scene file exists) and answers; the
work then runs in a worker thread while the current scene keeps ticking, and the result is
swapped in between two ticks and logged. A change the work refuses (a malformed scene)
changes nothing: the parameters are set back to what runs, and the reason is logged and
shown on /diagnostics. Every other change applies at once. Changes made while a preparation
runs are prepared together once it ends, so what runs is always what was asked for last.
"""
from dataclasses import replace
import threading

from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.parameter import Parameter

from rigid_sim import parameters
from rigid_sim.core.text import shown
from rigid_sim.resources import find_scene

HEAVY = ('scene', 'integrator', 'tolerance')   # settings whose change needs preparing
POLL = 0.01   # s of wall time between two looks at a running preparation


class Preparation:
    """``work()`` run in a daemon thread (a stop never waits for it); its result or error."""

    def __init__(self, settings, work):
        self.settings = settings
        self.result = self.error = None
        self.finished = threading.Event()
        self._work = work
        threading.Thread(target=self._run, daemon=True, name='rigid_sim prepare').start()

    def _run(self):
        try:
            self.result = self._work()
        except Exception as error:  # noqa: B902  reported as the refusal, never raised
            self.error = error
        self.finished.set()


class Reconfiguration:
    """The node's parameter callbacks and the preparations they start.

    Parameters
    ----------
    node : rigid_sim.node.RigidSimNode
        Provides ``settings``, ``prepare(settings, scene_changed)`` (the work, run in the
        worker), ``swap(settings, prepared)`` and ``apply(previous)`` (light changes).
    """

    def __init__(self, node):
        self._node = node
        self.accepted = node.settings   # what the parameters say; node.settings is what runs
        self.last_refusal = ''
        self._proposed = None
        self._preparation = None
        self._reverting = False
        self._scene_asked = False       # the scene was set again since the last preparation
        self._poll = node.create_timer(POLL, self._on_poll,
                                       clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._poll.cancel()
        node.add_on_set_parameters_callback(self._on_set)
        node.add_post_set_parameters_callback(self._on_post_set)

    @property
    def preparing(self):
        """Return whether a preparation runs or waits to be swapped in."""
        return self._preparation is not None

    def _on_set(self, changes):
        try:
            proposed = parameters.updated(self.accepted, changes)
            names = {change.name for change in changes}
            if 'scene' in names and not self._reverting:
                find_scene(proposed.scene, proposed.resource_paths)   # refused at once
            elif 'world_frame' in names:
                self._node.check_frames(proposed)
        except (ValueError, OSError) as error:
            return SetParametersResult(successful=False, reason=str(error))
        self._proposed = (proposed, 'scene' in names and not self._reverting)
        return SetParametersResult(successful=True)

    def _on_post_set(self, changes):
        (proposed, scene_set), self._proposed = self._proposed, None
        self.accepted = proposed
        self._scene_asked |= scene_set
        node = self._node
        previous = node.settings
        node.settings = replace(proposed, **{name: getattr(previous, name) for name in HEAVY})
        node.apply(previous)
        if self._reverting:
            return
        if self._scene_asked or self._heavy_change(previous):
            self._start()

    def _heavy_change(self, running):
        return any(getattr(self.accepted, name) != getattr(running, name) for name in HEAVY)

    def _start(self):
        if self._preparation is not None:   # started again with the newest once it ends
            return
        scene_changed, self._scene_asked = self._scene_asked, False
        scene_changed |= self.accepted.scene != self._node.settings.scene
        settings = self.accepted
        self._preparation = Preparation(
            settings, lambda: self._node.prepare(settings, scene_changed))
        self._preparation.scene_changed = scene_changed
        self._poll.reset()

    def _on_poll(self):
        if self._preparation is not None and self._preparation.finished.is_set():
            self._conclude()

    def wait(self, timeout=None):
        """Block until the running preparation (if any) is swapped in or refused; whether it is.

        For tests and embedding code that tick the node themselves.
        """
        while self._preparation is not None:
            if not self._preparation.finished.wait(timeout):
                return False
            self._conclude()
        return True

    def _conclude(self):
        done, self._preparation = self._preparation, None
        self._poll.cancel()
        newer = done.settings != self.accepted or self._scene_asked
        if done.error is None and not newer:
            self._node.swap(done.settings, done.result)
        elif done.error is not None and not newer:
            self._refuse(done)
        if newer:
            self._start()

    def _refuse(self, done):
        what = 'scene ' + shown(done.settings.scene) if done.scene_changed else (
            f'integrator {done.settings.integrator} (tolerance {done.settings.tolerance:g})')
        self.last_refusal = f'{what}: {done.error}'  # the loader cuts what it quotes
        running = self._node.settings
        self._node.get_logger().error(
            f'refused {self.last_refusal}; still running {shown(running.scene)} with '
            f'{running.integrator}, parameters set back')
        self._reverting = True
        try:
            self._node.set_parameters_atomically(
                [Parameter(name, value=getattr(running, name)) for name in HEAVY])
        finally:
            self._reverting = False
