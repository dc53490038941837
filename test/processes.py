# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Processes the tests start: each in a process group of its own, every group ended.

A node process, or ``node_forks.py`` and the twenty nodes it forks, runs in its own session
(``start_new_session``), so that killing its group ends whatever it started as well; killing
the first process alone leaves forked children running. Every group :func:`start` makes is
remembered: ``conftest.py`` ends those a test left (a finaliser that runs however the test
ended), and the rest when the run ends, even after a timeout or an interrupt.
"""
import atexit
import os
import signal
import subprocess
import time

EXIT_TIMEOUT = 60.0   # s: a killed group's first process is reaped within this, on any load
GRACE = 20.0          # s a group has to end on SIGTERM before SIGKILL (nodes: ~0.1 s)
_started = []         # every Popen started here, in order


def start(command, **options):
    """``subprocess.Popen(command, **options)`` in a new session; the Popen."""
    process = subprocess.Popen(command, start_new_session=True, **options)
    _started.append(process)
    return process


def started():
    """Return how many processes have been started so far (a mark for :func:`end_since`)."""
    return len(_started)


def end(process):
    """End ``process``'s whole group and reap the process; its exit status.

    SIGTERM first, so that a node destroys itself before it ends; SIGKILL for what is left
    after GRACE. A node killed outright may die while a DDS thread of it holds another
    process's shared-memory port lock, which hangs every later node that sends there
    (docs/ros_notes.md, "Shutdown"). Harmless when the process has ended already: what it
    forked may still be running in its group.
    """
    _signal_group(process.pid, signal.SIGTERM)
    deadline = time.monotonic() + GRACE
    while _group_running(process.pid) and time.monotonic() < deadline:
        process.poll()   # the first process, once ended, is reaped, not left a zombie
        time.sleep(0.05)
    _signal_group(process.pid, signal.SIGKILL)
    try:
        return process.wait(timeout=EXIT_TIMEOUT)
    except subprocess.TimeoutExpired:
        return None


def _signal_group(group, number):
    try:
        os.killpg(group, number)
    except (ProcessLookupError, PermissionError):
        pass   # nothing left in the group


def _group_running(group):
    """Whether a process of process group ``group`` runs (a zombie has ended)."""
    for entry in os.scandir('/proc'):
        if entry.name.isdigit():
            try:
                with open(f'/proc/{entry.name}/stat') as stat:
                    fields = stat.read().rpartition(')')[2].split()
            except (FileNotFoundError, ProcessLookupError):
                continue
            if int(fields[2]) == group and fields[0] not in ('Z', 'X'):
                return True
    return False


def end_since(mark):
    """End every group started since ``mark`` (see :func:`started`)."""
    for process in _started[mark:]:
        end(process)


def alive(pid):
    """Whether process ``pid`` exists and has not ended (a zombie has ended)."""
    try:
        with open(f'/proc/{pid}/stat') as stat:
            state = stat.read().rpartition(')')[2].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ('Z', 'X')


def _end_all_then_die(number, frame):
    """End every group, then die of the signal ``number`` as the default action would."""
    end_since(0)
    signal.signal(number, signal.SIG_DFL)
    os.kill(os.getpid(), number)


atexit.register(end_since, 0)
# A signal that ends the run (timeout(1)'s or a CI runner's SIGTERM, a closed terminal's
# SIGHUP) skips atexit: a node a helper's timed-out run started ticked on for an hour.
for _number in (signal.SIGTERM, signal.SIGHUP):
    if signal.getsignal(_number) is signal.SIG_DFL:
        signal.signal(_number, _end_all_then_die)
