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
of the executor. While paused the loop then stands still (there is nothing to catch up and
nothing new to publish); ``~/step`` still advances it.

Control apart from the work: one timer callback ticks for at most ``SLICE`` seconds of wall
time, then returns to the executor, which answers services, parameter calls and signals
before the next slice. A catch-up, the ticks of a multi-tick :class:`StepJob` and ticking
at rate 0 all run in such slices, and so does a single tick longer than a slice (many
``substeps``, many bodies): the tick is told the slice's end and stops after the world
step that passes it, to go on in the next callback; it counts as run once it is done.
"""
from collections import deque
import math
from time import monotonic, perf_counter

from rclpy.clock import Clock, ClockType

from rigid_sim.deferred import REQUEST_QUEUE_DEPTH

# Step jobs that may wait at once: as many calls as a service keeps in its queue.
MAX_QUEUED_JOBS = REQUEST_QUEUE_DEPTH
MAX_LAG = 0.1    # s of wall time the simulation may fall behind before ticks are given up
# s of wall time of ticks in one executor round: control is answered between two slices,
# so this (plus one tick) bounds its latency, well under the 100 ms the node promises.
SLICE = 0.02


class StepJob:
    """Ticks asked for by one ``~/step`` call, run in slices; ``done(ran, why)`` at the end.

    ``why`` is '' when every tick ran, else what ended the job early.
    """

    def __init__(self, ticks, done):
        self.left = ticks
        self.ran = 0
        self.why = ''   # what ends it early, once something does
        self._done = done

    def finish(self, why=''):
        """End the job: report the ticks it ran."""
        self.left = 0
        self._done(self.ran, why or self.why)


class TickLoop:
    """Calls ``tick`` ``rate`` times per second of wall time on average, or as fast as it can.

    Parameters
    ----------
    node : rclpy.node.Node
        Owns the timers.
    tick : callable
        ``tick(advance, until)``: one tick of the simulation, or the rest of the one in
        progress; ``advance`` False while paused; ``until`` a ``perf_counter`` time at
        which to stop early. Returns False when it stopped early (the tick is not done).
    rate : float
        Ticks per second of wall time, Hz; 0 ticks as fast as the CPU allows.
    """

    def __init__(self, node, tick, rate):
        self._tick = tick
        self.rate = rate
        self.paused = False
        self.stopped = False    # stopped for good: someone else calls the tick
        self.dropped = 0        # ticks given up behind wall time since the last report
        self.last_tick = monotonic()   # wall time of the latest tick, for /diagnostics
        self.jobs = deque()     # StepJobs, run in order, each to its end
        self.partial = False    # a tick stopped at a slice's end, to go on at the next call
        self._origin = 0.0      # wall time (monotonic) at which tick 0 was due
        self._done = 0          # ticks run since the origin
        # STEADY_TIME: never sim time, which this loop makes.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.timer = node.create_timer(self._period(rate), self._on_timer, clock=steady)
        self._job_timer = node.create_timer(0.0, self._on_job_timer, clock=steady)
        self._job_timer.cancel()
        self._restart()

    @staticmethod
    def _period(rate):
        return 1.0 / rate if rate > 0.0 else 0.0

    def _restart(self):
        self._origin = monotonic() + self._period(self.rate)
        self._done = 0

    def set_rate(self, rate):
        """Tick ``rate`` times per second (0: as fast as possible), the first a period from now.

        The timer is reset too: a changed period alone would wait out the old one first.
        """
        self.rate = rate
        self.timer.timer_period_ns = round(1e9 * self._period(rate))
        if not self.stopped:
            self.timer.reset()
        self._restart()
        self.set_paused(self.paused)

    def set_paused(self, paused):
        """At rate 0 a paused loop stands still; at a wall rate it keeps publishing."""
        self.paused = paused
        if self.stopped:
            return
        if self.rate == 0.0 and paused and not self.partial:   # else once the tick is done
            self.timer.cancel()
        elif self.timer.is_canceled() and not paused:
            self.timer.reset()
            self._restart()

    def stop(self):
        """Tick no more on the wall clock (tests and embedding code then tick themselves).

        Step jobs still run, in slices, when the executor spins.
        """
        self.stopped = True
        self.timer.cancel()

    def run_job(self, job):
        """Queue ``job``; its ticks run in slices after those of the jobs before it.

        Refused (ended at once, saying why) when MAX_QUEUED_JOBS wait already: each holds an
        unanswered call, and a client that kept calling would queue them without end.
        """
        if len(self.jobs) >= MAX_QUEUED_JOBS:
            job.finish(f'refused: {len(self.jobs)} step calls wait already, at most '
                       f'{MAX_QUEUED_JOBS}')
            return
        self.jobs.append(job)
        self._job_timer.reset()

    def end_jobs(self, why):
        """End the running job after its current tick, and every queued one, saying ``why``.

        A tick stopped at a slice's end is finished first (the world is left at the end of
        a tick, never within one): the running job then ends at its next round.
        """
        running = None
        if self.partial and self.jobs:
            running = self.jobs.popleft()
            running.left, running.why = 1, why
        while self.jobs:
            self.jobs.popleft().finish(why)
        if running is None:
            self._job_timer.cancel()
        else:
            self.jobs.append(running)

    def since_last_tick(self):
        """Seconds of wall time since the latest tick; None where none is due on the clock."""
        if self.stopped or self.rate == 0.0:
            return None
        return monotonic() - self.last_tick

    def take_dropped(self):
        """Ticks given up since the last call, and start counting again."""
        dropped, self.dropped = self.dropped, 0
        return dropped

    def _run(self, advance, until):
        """Run a tick, or the rest of the one in progress, until ``until``; whether it is done."""
        self.partial = self._tick(advance, until) is False
        if not self.partial:
            self.last_tick = monotonic()
        return not self.partial

    def _on_timer(self):
        if self.jobs:   # a step job ticks the world; the schedule starts again after it
            self._restart()
            return
        if self.rate == 0.0:
            end = perf_counter() + SLICE
            while self._run(not self.paused, end) and not self.paused and perf_counter() < end:
                pass
            if self.paused and not self.partial:   # paused while a tick was under way
                self.timer.cancel()
            return
        self._catch_up()

    def _catch_up(self):
        now = monotonic()
        owed = math.floor((now - self._origin) * self.rate) + 1 - self._done
        bound = max(1, math.ceil(MAX_LAG * self.rate))
        if owed > bound:
            self.dropped += owed - 1
            self._origin, self._done, owed = now, 0, 1
        end = perf_counter() + SLICE
        for ran in range(1, owed + 1):   # the rest, if any, at the next wake-up
            if not self._run(not self.paused, end):
                return
            self._done += 1
            if perf_counter() > end and ran < owed:
                return

    def _on_job_timer(self):
        end = perf_counter() + SLICE
        while self.jobs and perf_counter() <= end:
            job = self.jobs[0]
            while job.left > 0 and perf_counter() <= end:
                if not self._run(True, end):
                    return   # the tick goes on in the next round
                job.left -= 1
                job.ran += 1
            if job.left == 0:
                self.jobs.popleft().finish(job.why)
        if not self.jobs:
            self._job_timer.cancel()
