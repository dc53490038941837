# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Start many ``rigid_sim_node`` processes fast: import once, then fork one child per node.

Run as ``python node_forks.py LOG_DIR RUNS_JSON`` where RUNS_JSON is a list of ROS argument
lists. Prints one JSON line with the children's pids, waits for them all and prints one
JSON line with their exit statuses (a negative one: killed by that signal) and the wall
times (``time.time()``) at which they were seen to exit. Each child runs
:func:`rigid_sim.main.executable` exactly as the console script does, its output in
``LOG_DIR/node<i>.log``. rclpy is imported here but never initialised before the fork.
"""
import json
import os
import sys
import time
import traceback

from rigid_sim import main as entry


def child(index, arguments, log_dir):
    """Run one node with its output in its own log file; never return."""
    log = os.open(os.path.join(log_dir, f'node{index}.log'),
                  os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(log, 1)
    os.dup2(log, 2)
    sys.argv = ['rigid_sim_node', '--ros-args', *arguments]
    try:
        entry.executable()   # ends the process with the node's status
    except BaseException:  # what the console script would print, then its status
        traceback.print_exc()
        sys.stderr.flush()
        os._exit(1)


def run(log_dir, runs):
    pids = []
    for index, arguments in enumerate(runs):
        pid = os.fork()
        if pid == 0:
            child(index, arguments, log_dir)
        pids.append(pid)
    print(json.dumps(pids), flush=True)
    ended = {}
    while len(ended) < len(pids):
        pid, status = os.wait()
        ended[pid] = (os.waitstatus_to_exitcode(status), time.time())
    print(json.dumps([ended[pid] for pid in pids]), flush=True)


if __name__ == '__main__':
    run(sys.argv[1], json.loads(sys.argv[2]))
