# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The executable's loop: build the node, spin it until a stop is asked, shut it down.

:mod:`rigid_sim.main` installs the stop signals' handlers before importing this module,
which brings in rclpy, numba and scipy.
"""
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


def run(stopper):
    """Run the node until ``stopper.requested``; the exit status (1: the start was refused).

    Parameters
    ----------
    stopper : rigid_sim.main._Stopper
        Set by the stop signals; told when the node spins.
    """
    try:
        node = RigidSimNode()
    except (ParameterError, SceneError, FileNotFoundError) as error:
        rclpy.logging.get_logger(NODE_NAME).error(f'refused to start: {error}')
        return 1
    freeze_long_lived_objects()   # no full garbage collection stalls a tick from here on
    node.owner.keeps_heap_frozen = True   # nor one over what a scene edit builds
    executor = make_executor()
    executor.add_node(node)
    stopper.spinning = True
    try:
        while not stopper.requested:
            executor.spin_once(timeout_sec=SIGNAL_LATENCY)
    except ExternalShutdownException:
        pass
    ignore_stop_signals()
    executor.shutdown(timeout_sec=0)
    node.destroy_node()
    return 0
