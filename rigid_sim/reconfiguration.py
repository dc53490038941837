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
The preparation is a job of the node's :class:`~rigid_sim.world_owner.WorldOwner`, in turn
with scene edits, and swapped in by it.
"""
from dataclasses import replace
from functools import partial

from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter

from rigid_sim import parameters
from rigid_sim.core.text import shown
from rigid_sim.resources import find_scene
from rigid_sim.world_owner import Job

# Settings whose change needs preparing: a world, an integrator, or the messages of every
# body with other frame names (10 000 bodies': 3-6 s, which held control in the call).
HEAVY = ('scene', 'integrator', 'tolerance', 'world_frame', 'frame_prefix')


class Reconfiguration:
    """The node's parameter callbacks and the preparations they start.

    Parameters
    ----------
    node : rigid_sim.node.RigidSimNode
        Provides ``settings``, ``owner`` (the WorldOwner that runs the preparations),
        ``prepare(settings, scene_changed)`` (the work, run in the worker),
        ``swap(settings, prepared)`` and ``apply(previous)`` (light changes).
    """

    def __init__(self, node):
        self._node = node
        self.accepted = node.settings   # what the parameters say; node.settings is what runs
        self.at_start = node.settings   # the operator's: the ceiling of the resource limits
        self.last_refusal = ''
        self._proposed = None
        self._job = None                # the preparation asked for, queued, not begun
        self._running = None            # the preparation begun, until it concludes
        self._reverting = False
        self._scene_asked = False       # the scene was set again since the last preparation
        node.add_on_set_parameters_callback(self._on_set)
        node.add_post_set_parameters_callback(self._on_post_set)

    @property
    def preparing(self):
        """Return whether a preparation waits, runs or waits to be swapped in."""
        return self._job is not None or self._running is not None

    def _on_set(self, changes):
        try:
            proposed = parameters.updated(self.accepted, changes, self.at_start)
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
        if node.settings != previous:   # a job prepared with the settings before is stale
            node.owner.changed()
        if self._reverting:
            return
        if self._scene_asked or self._heavy_change(previous):
            self._start()

    def _heavy_change(self, running):
        return any(getattr(self.accepted, name) != getattr(running, name) for name in HEAVY)

    def _start(self):
        # A change asked while one is prepared is queued at once, in turn with the edits:
        # an edit asked after it starts from it (a spawn is not lost to a later-run load),
        # and one asked before it is not held back behind it (no starving under a flood).
        if self._job is not None:   # queued: it prepares the newest when it begins
            return
        job = self._job = Job(None, None)
        job.begin, job.conclude = partial(self._begin, job), partial(self._conclude, job)
        job.scene_changed = False
        self._node.owner.submit(job)

    def _begin(self, job, scene, world, running):
        """Decide what ``job`` prepares when its turn comes (again): the newest parameters."""
        node = self._node
        if self._job is job:
            self._job = None
        self._running = job
        job.scene_changed |= self._scene_asked or self.accepted.scene != running.scene
        self._scene_asked = False
        settings = job.settings = self.accepted
        scene_changed = job.scene_changed
        return lambda: node.prepare(settings, scene_changed)

    def wait(self, timeout=None):
        """Block until the running preparation (if any) is swapped in or refused; whether it is.

        For tests and embedding code that tick the node themselves.
        """
        return self._node.owner.wait(timeout)

    def _conclude(self, job, done):
        self._running = None
        if self._job is not None:   # asked again meanwhile: that one, queued, prepares it
            return
        if job.settings != self.accepted or self._scene_asked:   # set back meanwhile
            self._start()
        elif done.error is None:
            self._node.swap(job.settings, done.result)
        else:
            self._refuse(job, done.error)

    def _refuse(self, job, error):
        what = 'scene ' + shown(job.settings.scene) if job.scene_changed else (
            f'integrator {job.settings.integrator} (tolerance {job.settings.tolerance:g}, '
            f'world_frame {job.settings.world_frame}, frame_prefix '
            f'"{job.settings.frame_prefix}")')
        self.last_refusal = f'{what}: {error}'  # the loader cuts what it quotes
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
