# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Part of ``rigid_sim_bench startup``: a node process's start to its first tick, and load.

The node runs as the README's run command starts it (the executable's entry point, in its
own process, its own kernel cache); a listener in this process takes the first ``/clock``
message, which the node publishes at its first tick, as the end. The machine is usually
shared, so :class:`OtherLoad` says how busy other processes kept it meanwhile.
"""
import os
import resource
import signal
import subprocess
import sys
import time

READY_TIMEOUT = 300.0   # s; a liveness bound only
EXIT_TIMEOUT = 30.0     # s


def first_clock(scene, integrator, cache_dir, log_dir):
    """Wall seconds from starting a node process on ``scene`` to its first ``/clock``.

    ``cache_dir`` is its ``NUMBA_CACHE_DIR`` (empty: a cold start), ``log_dir`` its ROS log
    directory; ``ROS_DOMAIN_ID`` comes from the environment. NaN if no ``/clock`` came.
    """
    import rclpy
    from rosgraph_msgs.msg import Clock
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(os.environ['ROS_DOMAIN_ID']))
    listener = rclpy.create_node('first_tick', context=context)
    ticked = []
    listener.create_subscription(Clock, '/clock', lambda _: ticked.append(time.perf_counter()),
                                 10)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(listener)
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), ROS_LOG_DIR=str(log_dir))
    start = time.perf_counter()
    node = subprocess.Popen(
        [sys.executable, '-c', 'from rigid_sim import main; main.executable()', '--ros-args',
         '-p', f'scene:={scene}', '-p', f'integrator:={integrator}'],
        env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while not ticked and node.poll() is None and time.perf_counter() - start < READY_TIMEOUT:
            executor.spin_once(timeout_sec=0.01)
        node.send_signal(signal.SIGTERM)
        node.wait(EXIT_TIMEOUT)
    finally:
        if node.poll() is None:
            node.kill()
        executor.shutdown()
        listener.destroy_node()
        rclpy.try_shutdown(context=context)
    return ticked[0] - start if ticked else float('nan')


def _busy_and_ours():
    """Jiffies (1/100 s) the machine's cores were busy, and this process's and children's."""
    with open('/proc/stat') as stat:
        fields = [int(value) for value in stat.readline().split()[1:]]
    busy = sum(fields) - fields[3] - fields[4]   # all but idle and iowait
    ours = sum(getattr(resource.getrusage(who), field)
               for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
               for field in ('ru_utime', 'ru_stime'))
    return busy, 100.0 * ours


class OtherLoad:
    """How busy processes other than this one and its children kept the cores, from now on."""

    def __init__(self):
        self._start = _busy_and_ours()
        self._started = time.monotonic()

    def fraction(self):
        """Return the share of all cores' time, 0 to 1, that others used since construction."""
        busy, ours = _busy_and_ours()
        elapsed = 100.0 * (time.monotonic() - self._started) * os.cpu_count()
        others = (busy - self._start[0]) - (ours - self._start[1])
        return min(max(others / elapsed, 0.0), 1.0) if elapsed > 0.0 else 0.0
