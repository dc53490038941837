# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's control services: pause, step (lockstep) and reset."""
from std_srvs.srv import SetBool, Trigger


class SimControl:
    """``~/pause``, ``~/step`` and ``~/reset``, and whether integration is paused.

    Parameters
    ----------
    node : rclpy.node.Node
        Serves the services.
    paused : bool
        Whether integration starts paused.
    reset : callable
        ``reset()`` sends the simulation back to its initial state.
    step : callable
        ``step()`` advances ``step_ticks`` ticks, publishing each, and returns how many.
    now : callable
        ``now()`` is the current simulated time, s.
    paused_changed : callable
        ``paused_changed(paused)`` is told every change of the pause state.
    """

    def __init__(self, node, paused, reset, step, now, paused_changed):
        self.paused = paused
        self._reset, self._step, self._now = reset, step, now
        self._paused_changed = paused_changed
        node.create_service(Trigger, '~/reset', self._on_reset)
        node.create_service(SetBool, '~/pause', self._on_pause)
        node.create_service(Trigger, '~/step', self._on_step)

    def _on_reset(self, request, response):
        self._reset()
        response.success, response.message = True, 'back to the initial state at time 0'
        return response

    def _on_pause(self, request, response):
        self.paused = bool(request.data)
        self._paused_changed(self.paused)
        response.success = True
        response.message = f'{"paused" if self.paused else "running"} at {self._now():g} s'
        return response

    def _on_step(self, request, response):
        # repr: the shortest text that reads back as the same float, so a client can
        # parse the exact simulated time.
        if not self.paused:
            response.success = False
            response.message = (f'refused: ~/step advances only while paused (running at '
                                f'{self._now()!r} s); call ~/pause with true first')
            return response
        ticks = self._step()
        response.success = True
        response.message = f'advanced {ticks} ticks to {self._now()!r} s'
        return response
