# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The executor that ``rigid_sim_node`` spins, for the executable, its tests and benchmarks.

rclpy's EventsExecutor dispatches in C++ what the SingleThreadedExecutor rebuilds in Python
on every round (the wait set of every waitable of the node), so an idle round, which the tick
timer pays at every tick, costs a fraction as much (docs/ros_notes.md, "Executors and
timers"). Its ``spin()`` hangs on the Jazzy wheels, so callers loop on ``spin_once``.
"""
from rclpy.experimental import EventsExecutor


def make_executor(context=None):
    """Return the executor the node runs in, on ``context`` (default: rclpy's global one)."""
    return EventsExecutor(context=context)
