# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The throughput benchmark's wall-clock table: one thread against the bodies on threads.

From :data:`rigid_sim.core.dispatch.THREADED_BODIES` bodies a step whose effects each act on
one body shares the bodies among threads. CPU time adds up every thread's, so only wall time
shows what threads gain: this times ``World.step`` (the throughput benchmark's scene) by the
wall clock with the threads held off and made to run at every N, beside MuJoCo RK4 in the
same run. On a machine shared with other work, the other work takes cores from the threads.
"""
import contextlib
import math
import time

from rigid_sim import bench
from rigid_sim.core import dispatch

METHODS = ('rk4', 'exact_split')
SIZES = (1000, 10000, 100000)
QUICK_SIZES = (10,)
NEVER = float('inf')   # THREADED_BODIES that keeps every step in one call
MUJOCO_BODIES = 65533  # MuJoCo refuses a model of more bodies: no MuJoCo column beyond


@contextlib.contextmanager
def threads_from(bodies):
    """Worlds built within share their bodies among threads from ``bodies`` bodies.

    Both thresholds, the splittings' (``HEAVY_THREADED_BODIES``) too.
    """
    saved = dispatch.THREADED_BODIES, dispatch.HEAVY_THREADED_BODIES
    dispatch.THREADED_BODIES = dispatch.HEAVY_THREADED_BODIES = bodies
    try:
        yield
    finally:
        dispatch.THREADED_BODIES, dispatch.HEAVY_THREADED_BODIES = saved


def wall_sweep(sizes, work, repeats, with_mujoco):
    """Wall seconds per step, ``{row: {N: s}}``: each method in one call and on threads."""
    from rigid_sim.bench.throughput import mujoco_time, rigid_sim_time   # it imports this
    results = {}
    for name in METHODS:
        for row, threshold in ((f'{name}, one thread', NEVER), (f'{name}, threads', 0)):
            with threads_from(threshold):
                results[row] = {n: rigid_sim_time(n, name, work, repeats,
                                                  clock=time.perf_counter) for n in sizes}
    if with_mujoco:
        results['mujoco RK4'] = {
            n: mujoco_time(n, 'RK4', work, repeats, time.perf_counter) if n <= MUJOCO_BODIES
            else math.nan for n in sizes}
    return results


def wall_report(results, sizes):
    """Markdown: wall microseconds per body-step, and MuJoCo RK4's wall time over ours."""
    columns = [f'N = {n:g}' for n in sizes]
    rows = [[name] + [_shown(1e6 * times[n] / n) for n in sizes]
            for name, times in results.items()]
    threads = dispatch.config.NUMBA_NUM_THREADS
    parts = [f'### Wall time per body-step [us], one thread against {threads} threads (median of '
             'the repeats)',
             bench.markdown_table(['method'] + columns, rows)]
    if 'mujoco RK4' in results:
        reference = results['mujoco RK4']
        ratios = [[name] + [_shown(reference[n] / times[n]) for n in sizes]
                  for name, times in results.items() if not name.startswith('mujoco')]
        parts += ['', '### MuJoCo RK4 wall time per step over ours (> 1: ours is faster)',
                  bench.markdown_table(['MuJoCo RK4 / method'] + columns, ratios)]
    return '\n'.join(parts)


def _shown(value):
    """Three significant digits, ``-`` where MuJoCo could not run."""
    return '-' if math.isnan(value) else f'{value:.3g}'
