# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Services whose answer may be sent later, when the work a request started is done.

A multi-tick step is answered once its ticks have run, and they run in slices between which
the executor serves everything else (docs/design.md, "Control apart from the work"). rclpy
sends a service's answer as soon as its callback returns, and the EventsExecutor that
``rigid_sim_node`` spins does not run ``async`` callbacks (it sends the coroutine object as
the answer and raises; docs/ros_notes.md). Both executors send the answer through the
service's ``send_response(response, header)``, after the callback, on the same thread: a
callback that returns :data:`LATER` has that call keep the request's header instead, and the
answer goes out when the work calls its :class:`Reply`.
"""
from rclpy.qos import QoSProfile, ReliabilityPolicy

# Requests a service keeps waiting before DDS drops newer ones. A burst of this many calls
# from one client is answered in full (rclpy's default of 10 silently drops the rest); the
# client's own queue must be as deep to receive every answer.
REQUEST_QUEUE_DEPTH = 1000
SERVICE_QOS = QoSProfile(depth=REQUEST_QUEUE_DEPTH, reliability=ReliabilityPolicy.RELIABLE)


class _Later:
    """The answer a callback gives when it answers through a :class:`Reply` instead."""

    def __repr__(self):
        return 'LATER'


LATER = _Later()


class Reply:
    """Sends the answer to one request, once, whenever the work behind it is done."""

    def __init__(self, send):
        self._send = send
        self._header = None
        self._response = None
        self.sent = False

    def __call__(self, response):
        """Send ``response``; later calls do nothing, and so does a call after the node is gone."""
        if self.sent:
            return
        self.sent = True
        self._response = response
        if self._header is not None:
            self._deliver()

    def _addressed(self, header):
        self._header = header
        if self._response is not None:
            self._deliver()

    def _deliver(self):
        try:
            self._send(self._response, self._header)
        except Exception:  # noqa: B902  the service or its context is gone: nobody to answer
            pass


def create_service(node, srv_type, name, callback):
    """``node.create_service`` with a deep queue; ``callback(request, response, reply)``.

    The callback fills and returns ``response`` to answer at once, or returns :data:`LATER`
    and calls ``reply(response)`` later, on the executor's thread.
    """
    pending = []

    def take(request, response):
        reply = Reply(send_now)
        answer = callback(request, response, reply)
        if answer is LATER:
            pending.append(reply)
        return answer

    service = node.create_service(srv_type, name, take, qos_profile=SERVICE_QOS)
    send_now = service.send_response   # rclpy's own, which the override below calls

    def send_response(response, header):
        if response is LATER:
            pending.pop()._addressed(header)
            return
        send_now(response, header)

    service.send_response = send_response
    return service
