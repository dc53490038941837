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


def warm_up(world):
    """Compile or load every kernel ``world.step`` and its outputs use; seconds it took.

    The probe steps a copy of the state with a fresh integrator of the same kind, so the
    world, its integrator's counters and its diagnostics are left as they were.
    """
    start = time.perf_counter()
    integrator = make_integrator(world.integrator.name, world, world.integrator.tolerance)
    probe = world.y.copy()
    with np.errstate(all='ignore'):
        integrator.advance(probe, world.time, PROBE_STEP, 1)
    snapshot = world.snapshot()
    kinematics.largest_spin(world.y, world.bodies.model.inertia_inv, world.torqued,
                            world.inputs.held_mask, True)
    snapshot.angular_velocity
    world.wrench(snapshot)
    world.energy()
    return time.perf_counter() - start


class Compilations(event.Listener):
    """Counts numba's compilations (a kernel found in no cache) while it is installed.

    Parameters
    ----------
    on_first : callable or None
        Called with no argument as the first compilation starts.
    """

    def __init__(self, on_first=None):
        self.count = 0
        self._on_first = on_first

    def on_start(self, event):
        """Count one compilation; announce the first."""
        self.count += 1
        if self.count == 1 and self._on_first is not None:
            self._on_first()

    def on_end(self, event):
        """Nothing to do when a compilation ends."""


def warm_up_reporting(world, on_first_compile=None):
    """Run :func:`warm_up`, calling ``on_first_compile`` if a kernel has to be compiled.

    Parameters
    ----------
    world : World
        The world whose kernels are compiled or loaded; left as it was.
    on_first_compile : callable or None
        Called with no argument just before the first compilation, not at all when every
        kernel is already in memory or loaded from the disk cache.

    Returns
    -------
    seconds : float
        Wall time of the warm-up, s.
    compiled : int
        Number of kernel specialisations compiled (0: all were compiled or cached before).
    """
    compilations = Compilations(on_first_compile)
    with event.install_listener('numba:compile', compilations):
        seconds = warm_up(world)
    return seconds, compilations.count
