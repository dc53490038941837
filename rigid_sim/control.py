# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's control services: pause and reset."""
from std_srvs.srv import SetBool, Trigger


class SimControl:
    """``~/pause`` and ``~/reset``, and whether integration is paused.

    Parameters
    ----------
    node : rclpy.node.Node
        Serves the services.
    reset : callable
        Called without arguments to send the simulation back to its initial state.
    time : callable
        Returns the current simulated time, s, for the answers.
    """

    def __init__(self, node, reset, time):
        self.paused = False
        self._reset, self._time = reset, time
        node.create_service(Trigger, '~/reset', self._on_reset)
        node.create_service(SetBool, '~/pause', self._on_pause)

    def _on_reset(self, request, response):
        self._reset()
        response.success, response.message = True, 'back to the initial state at time 0'
        return response

    def _on_pause(self, request, response):
        self.paused = bool(request.data)
        response.success = True
        response.message = f'{"paused" if self.paused else "running"} at {self._time():g} s'
        return response
