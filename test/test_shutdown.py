# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""SIGINT, SIGTERM and SIGHUP stop a node process cleanly, whatever it is doing.

Twenty node processes at every kind of tick rate (1 kHz, 100 Hz, as fast as possible, one
tick per 1000 s) and paused, each signalled once at a different moment after it reported
that it is ready (so mostly mid-tick at the fast rates): each must exit with status 0 and
print no traceback and no rclpy error, and so must a node signalled while it compiles its
kernels. The twenty processes are forked from one that imported the package once
(``node_forks.py``), each then running the executable's ``main`` as the console script
does. How long each exit took after its signal is printed (``pytest -s``), not asserted: no
timed tests.
"""
import gc
import json
import os
import pty
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import processes

FORKS = Path(__file__).with_name('node_forks.py')
EXECUTABLE = Path(sys.executable).with_name('rigid_sim_node')
START_TIMEOUT = 600.0  # s: twenty nodes importing and discovering on a loaded 2-core machine
EXIT_TIMEOUT = 120.0   # s: a liveness bound, far above the exit times the benchmark shows
RATES = (['-p', 'rate:=1000.0'], ['-p', 'rate:=100.0'], ['-p', 'rate:=0.0'],
         ['-p', 'rate:=0.001', '-p', 'time_step:=0.01'], ['-p', 'start_paused:=true'])
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)   # SIGHUP: the terminal closed
RUNS = [(RATES[i % len(RATES)], SIGNALS[i % len(SIGNALS)], 0.01 * (i % 7)) for i in range(20)]
MARKS = ('Traceback', 'RCLError', 'terminate called', 'context is invalid', 'rror')


def test_twenty_signals_each_end_a_node_with_status_zero_and_no_traceback(tmp_path):
    namespace = f'/shutdown{os.getpid()}'
    arguments = [['-r', f'__ns:={namespace}/n{i}', *rate] for i, (rate, _, _) in enumerate(RUNS)]
    forks = processes.start([sys.executable, str(FORKS), str(tmp_path), json.dumps(arguments)],
                            stdout=subprocess.PIPE, text=True)
    signalled = []
    try:
        pids = json.loads(forks.stdout.readline())
        logs = [tmp_path / f'node{i}.log' for i in range(len(RUNS))]
        deadline = time.monotonic() + START_TIMEOUT
        for pid, log, (rate, number, delay) in zip(pids, logs, RUNS):
            while not (log.exists() and 'ready' in log.read_text()):
                assert time.monotonic() < deadline, f'{rate}: not started\n{log.read_text()}'
                time.sleep(0.02)
            time.sleep(delay)
            signalled.append(time.time())
            os.kill(pid, number)
        forks.wait(timeout=EXIT_TIMEOUT)
        ends = json.loads(forks.stdout.readline())
    finally:
        if forks.poll() is None:
            processes.end(forks)
    exits = sorted(end - start for (_, end), start in zip(ends, signalled))
    print(f'exit after the signal: median {exits[len(exits) // 2]:.3f} s, max {exits[-1]:.3f} s')
    for (status, _), log, (rate, number, delay) in zip(ends, logs, RUNS):
        output = log.read_text()
        what = f'{signal.Signals(number).name} {delay} s after start at {rate}'
        assert status == 0, f'{what}: exit status {status}\n{output}'
        assert not [mark for mark in MARKS if mark in output], f'{what}:\n{output}'


@pytest.mark.parametrize('number', SIGNALS)
def test_a_signal_while_the_kernels_compile_ends_the_node_with_status_zero(tmp_path, number):
    """A node with an empty kernel cache, signalled as it says it compiles, just ends."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / 'cache'))
    node = processes.start([str(EXECUTABLE), '--ros-args', '-r',
                            f'__ns:=/shutdown{os.getpid()}/compiling'],
                           env=environment, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
    try:
        lines = []
        while not (lines and 'compiling' in lines[-1]):
            lines.append(node.stdout.readline())
            assert lines[-1], f'ended before compiling:\n{"".join(lines)}'
        node.send_signal(number)
        output = ''.join(lines) + node.communicate(timeout=EXIT_TIMEOUT)[0]
    finally:
        if node.poll() is None:
            processes.end(node)
    assert node.returncode == 0, output
    assert not [mark for mark in MARKS if mark in output], output


def _participant_threads():
    """Return the names of this process's DDS participant threads (Fast DDS: ``dds.*``).

    Its shared-memory watchdog (``dds.shm.wdog``) is one per process, not a participant's.
    """
    names = [(task / 'comm').read_text().strip() for task in Path('/proc/self/task').iterdir()]
    return sorted(name for name in names if name.startswith('dds.') and name != 'dds.shm.wdog')


def test_a_destroyed_node_leaves_no_dds_participant_running(ros_context):
    """Destroyed as the executable destroys it, the node takes its participant with it.

    The process ends at once after (``os._exit``): a participant thread still sending then
    could die holding the lock of another process's shared-memory port, which hangs every node
    that sends there (docs/ros_notes.md, "Shutdown"). rclpy's ``destroy_node`` leaves the
    action server, which held the participant alive.
    """
    from rigid_sim.executor import make_executor
    from rigid_sim.node import RigidSimNode
    gc.collect()   # participants of earlier tests' contexts that only wait to be collected
    before = set(_participant_threads())
    node = RigidSimNode(context=ros_context)
    executor = make_executor(context=ros_context)
    executor.add_node(node)
    executor.spin_once(timeout_sec=0.1)
    made = set(_participant_threads()) - before
    assert made
    executor.shutdown(timeout_sec=0)
    node.destroy_node()
    assert not made & set(_participant_threads())


def test_a_closed_terminal_ends_the_node_with_status_zero():
    """The terminal the node runs in closes (its SIGHUP): the node ends as on SIGINT.

    SIGHUP's default ended the process at once (killed by signal 1), its DDS threads
    mid-send; the closed terminal then refuses the output of the node's last words.
    """
    pid, terminal = pty.fork()
    if pid == 0:   # the child: the executable, its terminal the pseudo-terminal
        os.execv(str(EXECUTABLE), [str(EXECUTABLE), '--ros-args', '-r',
                                   f'__ns:=/shutdown{os.getppid()}/terminal'])
    ended = (0, 0)   # (pid, status) once reaped
    try:
        output, deadline = b'', time.monotonic() + START_TIMEOUT
        while b'ready' not in output:
            assert time.monotonic() < deadline, output.decode(errors='replace')
            if select.select([terminal], [], [], 1.0)[0]:
                output += os.read(terminal, 65536)
        os.close(terminal)
        deadline = time.monotonic() + EXIT_TIMEOUT
        while (ended := os.waitpid(pid, os.WNOHANG))[0] == 0:
            assert time.monotonic() < deadline, 'the node did not end'
            time.sleep(0.01)
        assert os.waitstatus_to_exitcode(ended[1]) == 0
    finally:
        if ended[0] == 0:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
