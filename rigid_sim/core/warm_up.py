# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Compile cost made visible: compile (or load from numba's disk cache) a world's kernels.

Kernels compile lazily, the first time a world with that integrator and effect set steps,
and numba caches them on disk (``cache=True``) in a directory keyed on the core's sources
(:mod:`rigid_sim.core.compile_cache`). A first start therefore pays seconds of compilation
once; :func:`warm_up` lets a caller pay it at a moment of its choosing, and
:func:`warm_up_reporting` tells it whether anything compiled, as the first compilation
starts, so it can say so.
"""
import time

from numba.core import event
import numpy as np

from rigid_sim.core import kinematics
from rigid_sim.core.integrators import make_integrator

# A probe step this short changes no state anyone sees: it runs on a copy.
PROBE_STEP = 1e-6   # s
# s of wall time between two progress reports of a long compilation
PROGRESS_PERIOD = 2.0


def warm_up(world, integrator=None, imus=None):
    """Compile or load every kernel ``world.step`` and its outputs use; seconds it took.

    ``integrator`` (default: the world's) is the method whose kernels are wanted. The probe
    steps a copy of the state with a fresh integrator of the same kind, so the world, its
    integrator's counters and its diagnostics are left as they were. ``imus`` (the world's
    :class:`~rigid_sim.core.imu.Imus`, or None) adds their readings and the net wrench they
    read, which nothing else needs.
    """
    start = time.perf_counter()
    integrator = integrator or world.integrator
    integrator = make_integrator(integrator.name, world, integrator.tolerance)
    probe = world.y.copy()
    with np.errstate(all='ignore'):
        integrator.advance(probe, world.time, PROBE_STEP, 1, world.effect_parameters())
    if world.contact is not None:
        world.contact.probe(probe, PROBE_STEP, world.bodies.model)
    snapshot = world.snapshot()
    kinematics.largest_spin(world.y, world.bodies.model.inertia_inv, world.torqued,
                            world.inputs.held_mask, True)
    snapshot.angular_velocity
    world.energy()
    if imus is not None:
        imus.exact(world, list(range(len(imus.bodies))))   # noise-free: draws nothing
    return time.perf_counter() - start


class Compilations(event.Listener):
    """Counts numba's compilations (a kernel found in no cache) while it is installed.

    Parameters
    ----------
    on_first : callable or None
        Called with no argument as the first compilation starts.
    on_progress : callable or None
        ``on_progress(count, seconds)``, at most once every ``PROGRESS_PERIOD`` seconds while
        compilations go on: kernels compiled so far and seconds since the first started.
    """

    def __init__(self, on_first=None, on_progress=None):
        self.count = 0
        self._on_first, self._on_progress = on_first, on_progress
        self._started = self._reported = 0.0

    def on_start(self, event):
        """Count one compilation; announce the first."""
        self.count += 1
        if self.count == 1:
            self._started = self._reported = time.perf_counter()
            if self._on_first is not None:
                self._on_first()

    def on_end(self, event):
        """Report progress if the last report is ``PROGRESS_PERIOD`` old."""
        now = time.perf_counter()
        if self._on_progress is not None and now - self._reported >= PROGRESS_PERIOD:
            self._reported = now
            self._on_progress(self.count, now - self._started)


def warm_up_reporting(world, on_first_compile=None, on_progress=None, integrator=None,
                      imus=None):
    """Run :func:`warm_up`, calling ``on_first_compile`` if a kernel has to be compiled.

    Parameters
    ----------
    world : World
        The world whose kernels are compiled or loaded; left as it was.
    on_first_compile : callable or None
        Called with no argument just before the first compilation, not at all when every
        kernel is already in memory or loaded from the disk cache.
    on_progress : callable or None
        See :class:`Compilations`.
    integrator : Integrator or None
        See :func:`warm_up`.
    imus : Imus or None
        See :func:`warm_up`.

    Returns
    -------
    seconds : float
        Wall time of the warm-up, s.
    compiled : int
        Number of kernel specialisations compiled (0: all were compiled or cached before).
    """
    compilations = Compilations(on_first_compile, on_progress)
    with event.install_listener('numba:compile', compilations):
        seconds = warm_up(world, integrator, imus)
    return seconds, compilations.count
