# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Entry point of the ``rigid_sim_node`` executable.

SIGINT and SIGTERM stop the node cleanly (exit status 0, no traceback) at any moment. rclpy's
own handlers are not installed: they shut the context down from the signal while a tick may
still be publishing, which then raises ("publisher's context is invalid"). Here a signal
while the node is built (its scene loaded, its kernels compiled or loaded from numba's
cache) ends the process at once: nothing it holds then needs an orderly release, and an
exception raised out of that code would unwind through llvmlite's callbacks, which cannot
pass it on and may crash on what it left half-built. Once the node spins, a signal only
asks the loop to stop, so the callback running (a tick, mid-way) ends normally, and then the
executor is left, the node destroyed and the context shut down in that order, by this
thread alone.
"""
import atexit
import os
import signal
import sys

# Only the standard library above: the handlers are installed before the heavy imports
# (rclpy, numba, scipy: about a second), so a signal in the first milliseconds is not lost.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Stopper:
    """The stop signals' handler: end the process before the node spins, ask the loop after."""

    def __init__(self):
        self.spinning = False
        self.requested = False

    def __call__(self, signum, frame):
        self.requested = True
        if not self.spinning:
            _end_process(0)


def ignore_stop_signals():
    """Ignore SIGINT and SIGTERM from now on (the node is on its way out)."""
    for number in STOP_SIGNALS:
        signal.signal(number, signal.SIG_IGN)


def _end_process(status):
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def main(args=None):
    """Run the node until SIGINT or SIGTERM; return 0, or 1 when the start is refused.

    A stop signal before the node spins ends the process at once, with status 0.
    """
    stopper = _Stopper()
    for number in STOP_SIGNALS:
        signal.signal(number, stopper)
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from rigid_sim import spin
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        return spin.run(stopper)
    finally:
        ignore_stop_signals()   # a second Ctrl-C must not break the clean-up
        rclpy.try_shutdown()


def executable():
    """Run :func:`main` as the ``rigid_sim_node`` executable, then end the process at once.

    Everything the node holds is released by then; what the interpreter would still do is
    unload numpy, scipy and rclpy object by object, which takes longer than all of the
    node's own shutdown: the exit handlers run, the output is flushed and the process ends
    with the status.
    """
    status = main()
    atexit._run_exitfuncs()
    _end_process(status)


if __name__ == '__main__':
    executable()
