# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The one owner of what the node runs: its scene, its world and its settings.

Everything that prepares a replacement for them off the executor (a parameter change of
``scene``, ``integrator`` or ``tolerance``, a spawn, a delete, a reset that puts the scene
back) is a :class:`Job` of the :class:`WorldOwner`. Jobs run one at a time, in the order
they were asked for, so each starts from what the one before it left: a spawn asked while
a scene reloads is made in the reloaded scene, a reset asked while a spawn is pending
removes that body too. A job records the owner's generation when it starts; the
generation counts every change of the scene, the world or the running settings (a light
parameter such as ``error_control`` is applied to the running world at once). A job whose
generation is no longer the owner's when its work ends is started again from what runs
now, never swapped in. :meth:`WorldOwner.swap` is the only place the node's scene, world
and settings are replaced, between two ticks (docs/design.md, "One owner of the World").
"""
from collections import deque
import gc
import queue
import threading

from rclpy.clock import Clock, ClockType

from rigid_sim.core.scene_edit import carry_over

POLL = 0.01   # s of wall time between two looks at a running job
# Swaps between two full collections where the heap is kept frozen: what a swap replaced is
# freed by its reference counts, but for ~35 objects an edit in reference cycles (rclpy's
# subscriptions and their event handlers, closures), which stay frozen until then.
SWAPS_PER_COLLECTION = 100


def _discard(replaced):
    """Drop what a swap replaced, in a thread: freeing a large scene's messages takes long."""
    while True:
        replaced.get()


_DISCARD = queue.SimpleQueue()
threading.Thread(target=_discard, args=(_DISCARD,), daemon=True,
                 name='rigid_sim discard').start()


class Preparation:
    """``work()`` run in a daemon thread (a stop never waits for it); its result or error."""

    def __init__(self, work):
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


class Job:
    """One preparation the owner runs.

    Parameters
    ----------
    begin : callable
        ``begin(scene, world, settings)``, on the executor when the job's turn comes (again,
        when it is redone): what runs then. Returns the work, a callable run in a worker
        thread, or None when there is nothing to prepare.
    conclude : callable
        ``conclude(preparation)``, on the executor, with the :class:`Preparation` (its
        ``result`` or ``error``), or None when ``begin`` returned None. Only called while
        the generation is still the one the job began at, so it may swap.
    """

    def __init__(self, begin, conclude):
        self.begin, self.conclude = begin, conclude
        self.generation = None    # the owner's generation when the job began
        self.preparation = None


class WorldOwner:
    """Runs the :class:`Job` s of ``node`` (a RigidSimNode) and swaps what they made in."""

    def __init__(self, node):
        self._node = node
        self.generation = 0
        self.redone = 0           # jobs started again because what runs changed meanwhile
        self._queue = deque()
        self._running = None
        self._poll = node.create_timer(POLL, self._on_poll,
                                       clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._poll.cancel()
        # Set by the executable, which froze what its node holds at start: a job's objects
        # (a scene of thousands of bodies, its messages) are then built with the cyclic
        # collector off, as each full collection walked them all under the interpreter lock
        # (0.1-0.4 s at a spawn into 5000 bodies), and frozen once swapped in.
        self.keeps_heap_frozen = False
        self._frozen_swaps = 0

    @property
    def busy(self):
        """Whether a job runs or waits for its turn."""
        return self._running is not None or bool(self._queue)

    @property
    def pending(self):
        """How many jobs run or wait for their turn."""
        return len(self._queue) + (self._running is not None)

    def submit(self, job):
        """Queue ``job``; it begins when every job asked before it has ended."""
        self._queue.append(job)
        self._next()

    def changed(self):
        """Say that what runs changed outside a swap (the settings): running jobs are stale."""
        self.generation += 1

    def _next(self):
        while self._running is None and self._queue:
            job = self._queue.popleft()
            node = self._node
            job.generation = self.generation
            work = job.begin(node.scene, node.world, node.settings)
            if work is None:
                job.conclude(None)
                continue
            if self.keeps_heap_frozen:
                gc.disable()
            job.preparation = Preparation(work)
            self._running = job
            self._poll.reset()
        if self._running is None and self.keeps_heap_frozen:
            gc.enable()

    def _on_poll(self):
        job = self._running
        if job is None or not job.preparation.finished.is_set():
            return
        self._running = None
        self._poll.cancel()
        if job.generation != self.generation:
            self.redone += 1
            self._queue.appendleft(job)   # begun again from what runs now, before the rest
        else:
            job.conclude(job.preparation)
        self._next()

    def _freeze(self):
        """Freeze what runs now, the cycles frozen garbage makes collected now and then."""
        self._frozen_swaps += 1
        if self._frozen_swaps >= SWAPS_PER_COLLECTION:
            self._frozen_swaps = 0
            gc.unfreeze()
            gc.collect()   # one full collection's stall every SWAPS_PER_COLLECTION swaps
        gc.freeze()

    def wait(self, timeout=None):
        """Block until every queued job has ended; whether they did (tests that tick)."""
        while self._running is not None:
            if not self._running.preparation.finished.wait(timeout):
                return False
            self._on_poll()
        return True

    def swap(self, settings=None, scene=None, world=None, kept=None, integrator=None,
             wiring=None, frame=None):
        """Run what a job made from the next tick on: the one place any of it is replaced.

        Parameters
        ----------
        settings : rigid_sim.parameters.Settings or None
            The new running settings (None: unchanged).
        scene, world : Scene and World, or None
            The new scene and its world (None: unchanged).
        kept : list of (int, int) or None
            For a scene edit: (old, new) body indices whose state, held wrenches and the
            time are carried into ``world``, after the inputs received so far are applied
            to the running one. None: ``world`` starts as built (a reload).
        integrator : rigid_sim.core.integrators.base.Integrator or None
            A new integrator for the running world (an integrator or tolerance change).
        wiring : tuple
            With ``scene``: what the node's ``plan_wiring`` made for it in the worker, so
            that what is done here does not grow with the bodies but for array copies.
        frame : tuple or None
            For a change of frame names: the messages the outputs' ``frame_messages`` made
            for them in the worker.
        """
        node = self._node
        previous = node.settings
        if world is not None and kept is not None:
            node.inputs.apply(node.world, node.scene, previous)   # nothing received is lost
            carry_over(node.world, world, kept)
        if settings is not None:
            node.settings = settings
        if world is not None:
            replaced = node.scene, node.world
            node.scene, node.world = scene, world
            _DISCARD.put((replaced, node.wire_scene(wiring)))
        if integrator is not None:
            node.world.integrator = integrator
        if self.keeps_heap_frozen:
            self._freeze()
        self.generation += 1
        # The running light settings, onto the world that runs now; a new scene was wired
        # with its frame names already.
        _DISCARD.put(node.apply(previous, frame, rewired=world is not None))
