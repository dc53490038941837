# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Entry point of the ``rigid_sim_node`` executable.

SIGINT and SIGTERM stop the node cleanly (exit status 0, no traceback) at any moment. rclpy's
own handlers are not installed: they shut the context down from the signal while a tick may
still be publishing, which then raises ("publisher's context is invalid"). Here a signal
while the node is built raises :class:`Stop`; once it spins, a signal only asks the loop to
stop, so the callback running (a tick, mid-way) ends normally, and then the executor is
left, the node destroyed and the context shut down in that order, by this thread alone.
"""
import atexit
import os
import signal
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions

from rigid_sim.core.scene import SceneError
from rigid_sim.executor import make_executor
from rigid_sim.node import NODE_NAME, RigidSimNode
from rigid_sim.parameters import ParameterError

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# s; the executor waits at most this long for work, so a signal that arrives while it
# waits (a slow rate, a paused loop) is acted on within this time.
SIGNAL_LATENCY = 0.05


class Stop(BaseException):
    """Raised by a stop signal; a BaseException, so no ``except Exception`` swallows it."""


class _Stopper:
    """The stop signals' handler: raise before the node spins, ask the loop to end after."""

    def __init__(self):
        self.spinning = False
        self.requested = False

    def __call__(self, signum, frame):
        self.requested = True
        if not self.spinning:
            raise Stop(signum)


def _drop_swallowed_stops(previous, stopper):
    """Wrap ``sys.unraisablehook`` so that a :class:`Stop` Python had to drop stays quiet.

    A signal landing inside a C callback (numba's LLVM object cache, while the node's
    warm-up loads or compiles kernels) raises Stop where Python can only report and drop
    it; the stop is already recorded in ``requested``, and the node never spins. The
    compiler objects it interrupted may then fail again in their finalizers (llvmlite's
    ``ObjectRef.__del__``): once a stop is requested, those are dropped too.
    """
    def hook(unraisable):
        """Pass on everything but a dropped Stop and what it left half-built in llvmlite."""
        if isinstance(unraisable.exc_value, Stop):
            return
        where = getattr(unraisable.object, '__module__', None) or ''
        if stopper.requested and where.startswith('llvmlite'):
            return
        previous(unraisable)
    return hook


def main(args=None):
    """Run the node until SIGINT or SIGTERM; return 0, or 1 when the start is refused."""
    stopper = _Stopper()
    sys.unraisablehook = _drop_swallowed_stops(sys.unraisablehook, stopper)
    for number in STOP_SIGNALS:
        signal.signal(number, stopper)
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        return _run(stopper)
    except (Stop, KeyboardInterrupt, ExternalShutdownException):
        return 0   # a signal while the node was built, before it spun
    finally:
        for number in STOP_SIGNALS:   # a second Ctrl-C must not break the clean-up
            signal.signal(number, signal.SIG_IGN)
        rclpy.try_shutdown()


def _run(stopper):
    try:
        node = RigidSimNode()
    except (ParameterError, SceneError, FileNotFoundError) as error:
        rclpy.logging.get_logger(NODE_NAME).error(f'refused to start: {error}')
        return 1
    executor = make_executor()
    executor.add_node(node)
    stopper.spinning = True
    try:
        while not stopper.requested:
            executor.spin_once(timeout_sec=SIGNAL_LATENCY)
    except ExternalShutdownException:
        pass
    stopper.spinning = False
    for number in STOP_SIGNALS:
        signal.signal(number, signal.SIG_IGN)
    executor.shutdown(timeout_sec=0)
    node.destroy_node()
    return 0


def executable():
    """Run :func:`main` as the ``rigid_sim_node`` executable, then end the process at once.

    Everything the node holds is released by then; what the interpreter would still do is
    unload numpy, scipy and rclpy object by object, which takes longer than all of the
    node's own shutdown: the exit handlers run, the output is flushed and the process ends
    with the status.
    """
    status = main()
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


if __name__ == '__main__':
    executable()
