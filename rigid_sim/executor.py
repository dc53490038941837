# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The executor that ``rigid_sim_node`` spins, for the executable, its tests and benchmarks.

rclpy's EventsExecutor dispatches in C++ what the SingleThreadedExecutor rebuilds in Python
on every round (the wait set of every waitable of the node), so an idle round, which the tick
timer pays at every tick, costs a fraction as much (docs/ros_notes.md, "Executors and
timers"). Its ``spin()`` hangs on the Jazzy wheels, so callers loop on ``spin_once``.
"""
import gc

from rclpy.experimental import EventsExecutor


def make_executor(context=None):
    """Return the executor the node runs in, on ``context`` (default: rclpy's global one)."""
    return EventsExecutor(context=context)


def freeze_long_lived_objects():
    """Keep every object alive now out of the cyclic garbage collector's passes, for good.

    A started node's process holds ~2e5 objects that live as long as it does (numba's,
    scipy's and rclpy's, the scene, the messages it refills). A full collection walks them
    all (~75 ms on the quiet 2-core machine of docs/performance.md, more under load) at
    whatever tick the allocation count triggers it, and a stall past the tick loop's
    ``MAX_LAG`` gives ticks up. Frozen, they are skipped; what is created later is still
    collected. Garbage is collected first so that none of it is frozen.
    """
    gc.collect()
    gc.freeze()
