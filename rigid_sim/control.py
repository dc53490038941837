# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's control services: pause, step (lockstep) and reset.

Every call is answered (queues of :data:`rigid_sim.deferred.REQUEST_QUEUE_DEPTH`). A
``~/step`` is a :class:`~rigid_sim.tick_loop.StepJob`: its ticks run in slices between which
the executor serves other calls, and it is answered when they have run, or when a ``~/pause``
call or a reset ends it early (the answer says how many ran).
"""
from std_srvs.srv import SetBool, Trigger

from rigid_sim import deferred
from rigid_sim.tick_loop import StepJob


class SimControl:
    """``~/pause``, ``~/step`` and ``~/reset``, and whether integration is paused.

    Parameters
    ----------
    node : rclpy.node.Node
        Serves the services.
    paused : bool
        Whether integration starts paused.
    loop : rigid_sim.tick_loop.TickLoop
        Runs step jobs and is told every change of the pause state.
    reset : callable
        ``reset()`` sends the simulation back to its initial state.
    step_ticks : callable
        ``step_ticks()`` is the number of ticks one ``~/step`` advances.
    now : callable
        ``now()`` is the current simulated time, s.
    """

    def __init__(self, node, paused, loop, reset, step_ticks, now):
        self.paused = paused
        self._loop = loop
        self._reset, self._step_ticks, self._now = reset, step_ticks, now
        self.before_step = lambda: None   # called as a step job is queued
        deferred.create_service(node, Trigger, '~/reset', self._on_reset)
        deferred.create_service(node, SetBool, '~/pause', self._on_pause)
        deferred.create_service(node, Trigger, '~/step', self._on_step)

    def _on_reset(self, request, response, reply):
        self._loop.end_jobs('ended by ~/reset')
        self._reset()
        response.success, response.message = True, 'back to the initial state at time 0'
        return response

    def set_paused(self, paused):
        """Pause or resume integration; a step job running or queued ends after its tick."""
        self._loop.end_jobs('ended by ~/pause')
        self.paused = paused
        self._loop.set_paused(paused)

    def _on_pause(self, request, response, reply):
        self.set_paused(bool(request.data))
        response.success = True
        response.message = f'{"paused" if self.paused else "running"} at {self._now():g} s'
        return response

    def _on_step(self, request, response, reply):
        # repr: the shortest text that reads back as the same float, so a client can
        # parse the exact simulated time.
        if not self.paused:
            response.success = False
            response.message = (f'refused: ~/step advances only while paused (running at '
                                f'{self._now()!r} s); call ~/pause with true first')
            return response
        self.start_steps(self._step_ticks(), lambda ran, why: reply(self._answer(
            response, ran, why)))
        return deferred.LATER

    def start_steps(self, ticks, done):
        """Queue a job of ``ticks`` ticks; ``done(ran, why)`` when it ends."""
        self.before_step()
        self._loop.run_job(StepJob(ticks, done))

    def _answer(self, response, ran, why):
        response.success = not why
        response.message = f'advanced {ran} ticks to {self._now()!r} s'
        if why:
            response.message += f' ({why})'
        return response
