# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Compile cost made visible: compile (or load from numba's disk cache) a world's kernels.

Kernels compile lazily, the first time a world with that integrator and effect set steps,
and numba caches them on disk (``cache=True``): in ``__pycache__`` next to the modules, or,
when the package directory is read-only (an install under /opt/ros), in numba's user-wide
cache directory (``NUMBA_CACHE_DIR`` if set, else the user's cache directory). A first
start therefore pays seconds of compilation once; :func:`warm_up` lets a caller pay it at a
moment of its choosing and say so.
"""
import time

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
