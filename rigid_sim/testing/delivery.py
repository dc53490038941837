# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""How the test kit settles an executor: deliver what is in flight, run what is ready."""
import time

from rclpy.duration import Duration
from rclpy.executors import TimeoutException
from rclpy.qos import ReliabilityPolicy

__all__ = ['Late', 'deliver', 'run_ready_callbacks', 'wait_until']
ACK_TIMEOUT = 5.0        # s of wall time for one publisher's messages to be delivered
MAX_ROUNDS = 1000        # rounds of delivery between two ticks before giving up


class Late(Exception):
    """A deadline of wall time has passed (the caller says what ran out of time)."""


def run_ready_callbacks(executor):
    """Run every callback of ``executor`` that is ready now, without waiting; how many ran."""
    ran = 0
    while True:
        try:
            handler, _, _ = executor.wait_for_ready_callbacks(timeout_sec=0.0)
        except TimeoutException:
            return ran
        handler()
        handler.result()   # raises what the callback raised
        ran += 1


def deliver(executor, deadline=None):
    """Deliver every message in flight and run callbacks until nothing is left to run.

    Reliable publishers are waited on until their subscribers have every message (best
    effort ones may still lose some). :class:`Late` once ``time.monotonic()`` passes
    ``deadline`` (None: never); RuntimeError after ``MAX_ROUNDS`` rounds.
    """
    for _ in range(MAX_ROUNDS):
        if deadline is not None and time.monotonic() >= deadline:
            raise Late
        for node in executor.get_nodes():
            for publisher in node.publishers:
                if publisher.qos_profile.reliability == ReliabilityPolicy.RELIABLE:
                    publisher.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT))
        if run_ready_callbacks(executor) == 0:
            return
    raise RuntimeError(f'callbacks still ran after {MAX_ROUNDS} rounds of delivery: '
                       'do they keep publishing to one another?')


def wait_until(executor, condition, timeout):
    """Spin ``executor`` until ``condition()`` holds; False if ``timeout`` s passed first."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        executor.spin_once(timeout_sec=0.01)
    return True
