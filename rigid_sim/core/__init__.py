# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The simulation core: scenes, bodies, effects and integrators, without ROS.

Importing it first points numba's disk cache at a directory keyed on the core's sources
(:mod:`rigid_sim.core.compile_cache`), before any kernel module is decorated.
"""
from rigid_sim.core.compile_cache import use_keyed_cache

CACHE_DIRECTORY = use_keyed_cache()
