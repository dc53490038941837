# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""What makes the node tick: a timer on the wall clock."""
from rclpy.clock import Clock, ClockType


class TickLoop:
    """Calls ``tick`` ``rate`` times per second of wall time.

    Parameters
    ----------
    node : rclpy.node.Node
        Owns the timer.
    tick : callable
        One tick of the simulation.
    rate : float, Hz
    """

    def __init__(self, node, tick, rate):
        wall_clock = Clock(clock_type=ClockType.STEADY_TIME)  # never sim time: we make it
        self.timer = node.create_timer(1.0 / rate, tick, clock=wall_clock)

    def set_rate(self, rate):
        """Tick ``rate`` times per second from now on."""
        self.timer.timer_period_ns = 1e9 / rate

    def stop(self):
        """Tick no more (tests and embedding code then call the tick themselves)."""
        self.timer.cancel()
