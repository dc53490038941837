# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Entry point of the ``rigid_sim_node`` executable.

SIGINT, SIGTERM and SIGHUP (a closed terminal) stop the node cleanly (exit status 0, no
traceback) at any moment. rclpy's own handlers are not installed: they shut the context
down from the signal while a tick may still be publishing, which then raises ("publisher's
context is invalid"). Here a signal
while the node is built (its scene loaded, its kernels compiled or loaded from numba's
cache) destroys the node and ends the process at once: nothing else it holds needs an
orderly release, and an exception raised out of that code would unwind through llvmlite's
callbacks, which cannot pass it on and may crash on what it left half-built. Once the
kernels are ready, a signal only asks to stop: the node's topics and services are made
(tens of ms), and once it spins the callback running (a tick, mid-way) ends normally; then
the executor is left, the node destroyed and the context shut down in that order, by this
thread alone.

The node is always destroyed before the process ends. Its DDS participant lives as long as
the process's last node, and a participant thread killed mid-send holds, for good, the lock
of another process's shared-memory port, so that every node that then sends there hangs
(docs/ros_notes.md, "Shutdown"). The node cannot be destroyed while it makes a topic or a
service (rclpy defers it), which is why a signal then only asks.
"""
import atexit
import os
import signal
import sys
import time

# Only the standard library above: the handlers are installed before the heavy imports
# (rclpy, numba, scipy: about a second), so a signal in the first milliseconds is not lost.
# SIGHUP: the terminal closed. Its default ends the process at once, mid-send, which can
# leave another process's Fast DDS shared-memory port locked (docs/ros_notes.md, "Shutdown").
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class _Stopper:
    """The stop signals' handler: end the process until the kernels are ready, then ask.

    Told by the node when it exists in the middleware and when its kernels are ready.
    """

    def __init__(self):
        self.started = time.monotonic()
        self.at_once = True
        self.requested = False
        self._node = None

    def __call__(self, signum, frame):
        self.requested = True
        if self.at_once:
            self.release_node()
            _end_process(0)

    def exists(self, node):
        """Hold ``node``, which the middleware knows from now on, to destroy it at a stop."""
        self._node = node

    def compiled(self):
        """From now on a stop signal only asks: the node makes its topics and services."""
        self.at_once = False

    def release_node(self):
        """Destroy the node held, half-built as it may be, so that no DDS thread outlives it."""
        node, self._node = self._node, None
        if node is not None:
            try:
                node.destroy_node()
            except Exception:  # noqa: B902  half-built: what it could not release ends anyway
                pass


def ignore_stop_signals():
    """Ignore the stop signals from now on (the node is on its way out)."""
    for number in STOP_SIGNALS:
        signal.signal(number, signal.SIG_IGN)


def _end_process(status):
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except OSError:   # a terminal that closed (SIGHUP) takes no more output
            pass
    os._exit(status)


def main(args=None):
    """Run the node until SIGINT, SIGTERM or SIGHUP; return 0, or 1 when the start is refused.

    A stop signal before the node spins ends the process at once, with status 0.
    """
    stopper = _Stopper()
    for number in STOP_SIGNALS:
        signal.signal(number, stopper)
    from rigid_sim.dds_profile import use_shipped_profile
    choice = use_shipped_profile()   # before rclpy.init, which makes the DDS participant
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from rigid_sim import spin
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        if choice.note is not None:
            logger = rclpy.logging.get_logger('rigid_sim')
            (logger.info if choice.profile is not None else logger.warning)(choice.note)
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
