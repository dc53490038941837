# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""What makes the node tick: simulated time locked to wall time, or as fast as possible.

With ``rate`` > 0, tick k is due at ``k / rate`` seconds of wall time after the loop
started. A timer wakes the loop once a period and the loop runs every tick that is due,
so a late wake-up (a slow tick, a busy executor) is caught up at the next one and simulated
time does not drift behind wall time, as a bare rclpy timer lets it (it skips the periods
it missed). Ticks more than ``MAX_LAG`` behind are given up rather than caught up, counted
and reported on /diagnostics: a simulation that cannot keep up says so instead of stalling
the executor with an ever longer backlog.

With ``rate`` 0 there is no wall-clock schedule: a zero-period timer ticks on every round
of the executor, in slices of at most ``SLICE`` seconds of wall time so that input messages
and service calls are served between slices. While paused the loop then stands still (there
is nothing to catch up and nothing new to publish); ``~/step`` still advances it.
"""
import math
from time import monotonic, perf_counter

from rclpy.clock import Clock, ClockType

MAX_LAG = 0.1    # s of wall time the simulation may fall behind before ticks are given up
SLICE = 1.0e-3   # s of wall time of ticks between two executor rounds at rate 0


class TickLoop:
    """Calls ``tick`` ``rate`` times per second of wall time on average, or as fast as it can.

    Parameters
    ----------
    node : rclpy.node.Node
        Owns the timer.
    tick : callable
        One tick of the simulation.
    rate : float
        Ticks per second of wall time, Hz; 0 ticks as fast as the CPU allows.
    """

    def __init__(self, node, tick, rate):
        self._tick = tick
        self.rate = rate
        self.paused = False
        self.stopped = False    # stopped for good: someone else calls the tick
        self.dropped = 0        # ticks given up behind wall time since the last report
        self._origin = 0.0      # wall time (monotonic) at which tick 0 was due
        self._done = 0          # ticks run since the origin
        # STEADY_TIME: never sim time, which this loop makes.
        self.timer = node.create_timer(self._period(rate), self._on_timer,
                                       clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._restart()

    @staticmethod
    def _period(rate):
        return 1.0 / rate if rate > 0.0 else 0.0

    def _restart(self):
        self._origin = monotonic() + self._period(self.rate)
        self._done = 0

    def set_rate(self, rate):
        """Tick ``rate`` times per second (0: as fast as possible) from now on."""
        self.rate = rate
        self.timer.timer_period_ns = round(1e9 * self._period(rate))
        self._restart()
        self.set_paused(self.paused)

    def set_paused(self, paused):
        """At rate 0 a paused loop stands still; at a wall rate it keeps publishing."""
        self.paused = paused
        if self.stopped:
            return
        if self.rate == 0.0 and paused:
            self.timer.cancel()
        elif self.timer.is_canceled() and not paused:
            self.timer.reset()
            self._restart()

    def stop(self):
        """Tick no more (tests and embedding code then call the tick themselves)."""
        self.stopped = True
        self.timer.cancel()

    def take_dropped(self):
        """Ticks given up since the last call, and start counting again."""
        dropped, self.dropped = self.dropped, 0
        return dropped

    def _on_timer(self):
        if self.rate == 0.0:
            self._run_slice()
            return
        now = monotonic()
        owed = math.floor((now - self._origin) * self.rate) + 1 - self._done
        bound = max(1, math.ceil(MAX_LAG * self.rate))
        if owed > bound:
            self.dropped += owed - 1
            self._origin, self._done, owed = now, 0, 1
        for _ in range(owed):
            self._tick()
        self._done += max(owed, 0)

    def _run_slice(self):
        end = perf_counter() + SLICE
        self._tick()
        while perf_counter() < end:
            self._tick()
