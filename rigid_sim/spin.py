# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The executable's loop: build the node, spin it until a stop is asked, shut it down.

:mod:`rigid_sim.main` installs the stop signals' handlers before importing this module,
which brings in rclpy, numba and scipy.
"""
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException

from rigid_sim.core.scene import SceneError
from rigid_sim.executor import freeze_long_lived_objects, make_executor
from rigid_sim.main import ignore_stop_signals
from rigid_sim.node import NODE_NAME, RigidSimNode
from rigid_sim.parameters import ParameterError

# s; the executor waits at most this long for work, so a signal that arrives while it
# waits (a slow rate, a paused loop) is acted on within this time.
SIGNAL_LATENCY = 0.05
# s a thread may keep the interpreter while another waits for it (Python's default 5 ms).
# A worker's Python (a goal solve, a scene edit) and the executor take turns: an answer
# needs the interpreter several times, each a wait of up to this. Measured on the
# control-latency bench's goal rows, two runs each, quiet machine: at 5 ms a springs goal
# held parameter calls to p99 135-159 ms, a goal flood to 67-87 ms (slowest 263-294 ms);
# at 0.5 ms 6-8 ms and 10-13 ms (slowest 15-21 ms) (docs/performance.md).
SWITCH_INTERVAL = 0.0005


def run(stopper):
    """Run the node until ``stopper.requested``; the exit status (1: the start was refused).

    Parameters
    ----------
    stopper : rigid_sim.main._Stopper
        Set by the stop signals; told when the node exists and when its kernels are ready.
    """
    try:
        node = RigidSimNode(start=stopper)
    except (ParameterError, SceneError, FileNotFoundError) as error:
        rclpy.logging.get_logger(NODE_NAME).error(f'refused to start: {error}')
        stopper.release_node()
        return 1
    freeze_long_lived_objects()   # no full garbage collection stalls a tick from here on
    node.owner.keeps_heap_frozen = True   # nor one over what a scene edit builds
    sys.setswitchinterval(SWITCH_INTERVAL)
    executor = make_executor()
    executor.add_node(node)
    node.get_logger().info(f'ready {time.monotonic() - stopper.started:.1f} s after the start: '
                           'answering services, parameters and topics')
    try:
        while not stopper.requested:
            executor.spin_once(timeout_sec=SIGNAL_LATENCY)
    except ExternalShutdownException:
        pass
    ignore_stop_signals()
    executor.shutdown(timeout_sec=0)
    node.destroy_node()
    return 0
