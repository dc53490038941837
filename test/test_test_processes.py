# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The suite's own hygiene: the user's ROS_DOMAIN_ID is kept, no started process outlives a test.

On a loaded machine a test that timed out once left twenty node processes running: killing
``node_forks.py`` alone leaves the nodes it forked. Each process a test starts now has a
process group of its own, which is ended however the test ends: asked with SIGTERM, then
killed.
"""
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from domains import own_domain
import processes

HERE = Path(__file__).parent
FORKS = HERE / 'node_forks.py'
START_TIMEOUT = 300.0   # s: two nodes importing and discovering on a loaded machine
GONE_TIMEOUT = 60.0     # s: a liveness bound for the kernel to end a killed group


def test_a_domain_id_the_user_set_is_kept():
    """conftest.py gives a run its own domain only where the user set none."""
    code = 'import os, conftest; print(os.environ["ROS_DOMAIN_ID"])'
    environment = dict(os.environ, ROS_DOMAIN_ID='215', PYTHONPATH=os.pathsep.join(
        [str(HERE), os.environ.get('PYTHONPATH', '')]))
    environment.pop('PYTEST_XDIST_WORKER', None)   # the child is a run, not a worker
    run = subprocess.run([sys.executable, '-c', code], cwd=HERE, capture_output=True, text=True,
                         env=environment, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ['215']   # 215: not among the 1..101 conftest picks


@pytest.mark.parametrize('chosen', ['', '7', '101', '215'])
def test_the_workers_of_a_run_each_take_a_domain_of_their_own(chosen):
    """Two or eight pytest-xdist workers: distinct domains, valid ones where the run's is."""
    for workers in (2, 8):
        domains = [own_domain({'ROS_DOMAIN_ID': chosen, 'PYTEST_XDIST_WORKER': f'gw{k}'},
                              pid=4242) for k in range(workers)]
        assert len(set(domains)) == workers
        if chosen != '215':
            assert all(1 <= domain <= 101 for domain in domains), domains
    assert own_domain({'ROS_DOMAIN_ID': chosen}, pid=4242) == int(chosen or 1 + 4242 % 101)


class Failed(Exception):
    """What a test that failed half-way raises."""


def test_a_test_that_fails_with_forked_nodes_running_leaves_none(tmp_path):
    """Two nodes forked by node_forks.py, then a failure: the group is killed, all of it."""
    namespace = f'/hygiene{os.getpid()}'
    runs = [['-r', f'__ns:={namespace}/n{i}', '-p', 'rate:=100.0'] for i in range(2)]
    forks = processes.start([sys.executable, str(FORKS), str(tmp_path), json.dumps(runs)],
                            stdout=subprocess.PIPE, text=True)
    pids = json.loads(forks.stdout.readline())
    logs = [tmp_path / f'node{i}.log' for i in range(len(runs))]
    with pytest.raises(Failed):
        try:
            deadline = time.monotonic() + START_TIMEOUT
            while not all(log.exists() and 'simulating' in log.read_text() for log in logs):
                assert time.monotonic() < deadline, 'the nodes did not start'
                assert forks.poll() is None
                time.sleep(0.05)
            assert all(processes.alive(pid) for pid in pids)
            raise Failed('half-way through')
        finally:
            processes.end(forks)
    deadline = time.monotonic() + GONE_TIMEOUT
    while any(processes.alive(pid) for pid in pids):
        assert time.monotonic() < deadline, 'a forked node outlived its test'
        time.sleep(0.05)


KEEPER = """
import sys, time
import processes
child = processes.start([sys.executable, '-c', 'import time; time.sleep(600)'])
print(child.pid, flush=True)
time.sleep(600)
"""


def test_a_run_ended_by_sigterm_ends_the_processes_it_started_first():
    """timeout(1) ends a test run with SIGTERM, which skips atexit: the groups end anyway."""
    import signal
    run = subprocess.Popen([sys.executable, '-c', KEEPER], cwd=HERE, stdout=subprocess.PIPE,
                           text=True, env=dict(os.environ, PYTHONPATH=os.pathsep.join(
                               [str(HERE), os.environ.get('PYTHONPATH', '')])))
    try:
        child = int(run.stdout.readline())
        assert processes.alive(child)
        run.send_signal(signal.SIGTERM)
        assert run.wait(timeout=GONE_TIMEOUT) == -signal.SIGTERM   # died of it, as before
        deadline = time.monotonic() + GONE_TIMEOUT
        while processes.alive(child):
            assert time.monotonic() < deadline, 'the started process outlived the run'
            time.sleep(0.05)
    finally:
        run.kill()
        run.wait()


ENDS_ON_SIGTERM = """
import signal, sys, time
signal.signal(signal.SIGTERM, lambda number, frame: sys.exit(0))
print('ready', flush=True)
time.sleep(600)
"""
IGNORES_SIGTERM = ENDS_ON_SIGTERM.replace('lambda number, frame: sys.exit(0)', 'signal.SIG_IGN')


def test_a_group_is_asked_to_end_before_it_is_killed():
    """SIGTERM first: a node then destroys itself (a SIGKILL mid-send can hang other nodes)."""
    process = processes.start([sys.executable, '-c', ENDS_ON_SIGTERM], stdout=subprocess.PIPE,
                              text=True)
    assert process.stdout.readline() == 'ready\n'
    assert processes.end(process) == 0


def test_a_group_that_ignores_sigterm_is_killed_after_the_grace(monkeypatch):
    import signal
    monkeypatch.setattr(processes, 'GRACE', 0.5)
    process = processes.start([sys.executable, '-c', IGNORES_SIGTERM], stdout=subprocess.PIPE,
                              text=True)
    assert process.stdout.readline() == 'ready\n'
    assert processes.end(process) == -signal.SIGKILL
