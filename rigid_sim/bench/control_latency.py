# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Control latency of ``rigid_sim_node``: calls answered and signals obeyed while it works.

Part of ``rigid_sim_bench node``. The executable runs in its own process, as a user starts
it; a client in this process, over DDS, times a parameter call (``get_parameters``, the
slowest of five) and a ``~/pause`` call from sending to answer, and then the process's exit
after SIGTERM, in three states of work: a 10 000-tick ``~/step`` of 1000 bodies, a runtime
switch to an integrator whose kernels are not in the (fresh) cache, and overload (1000
bodies at rate 1000, more than one core can tick). The node promises each answer within
100 ms and each stop within 0.5 s.
"""
import os
import signal
import subprocess
import sys
import tempfile
import time

import rclpy
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters
from std_srvs.srv import SetBool, Trigger

from rigid_sim.deferred import SERVICE_QOS

READY_TIMEOUT = 300.0   # s; a cold start compiles
ANSWER_TIMEOUT = 60.0   # s
EXIT_TIMEOUT = 60.0     # s
SAMPLES = 5             # parameter calls per state, one after the other; the slowest counts
# (state, node parameters, work started by the client, environment: a fresh kernel cache)
STATES = (
    ('long ~/step (1000 bodies, 10 000 ticks)',
     ['rate:=0.0', 'start_paused:=true', 'step_ticks:=10000', 'substeps:=5'], 'step', False),
    ('runtime compile (switch to exact_split4, cache empty)',
     ['rate:=100.0', 'integrator:=semi_implicit_euler'], 'compile', True),
    ('overload (1000 bodies at rate 1000)', ['rate:=1000.0'], 'overload', False),
)


class Client:
    """A node in its own context that calls the simulator's services and times the answers."""

    def __init__(self, domain_id):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node('control_latency', context=self.context)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._clients = {}

    def call(self, kind, name, request, timeout=ANSWER_TIMEOUT):
        """Send ``request`` to ``/rigid_sim/<name>``; (seconds to the answer, answer).

        The client for a service is made once, so only the first call waits on discovery.
        """
        client = self._clients.get(name)
        if client is None:
            client = self._clients[name] = self.node.create_client(
                kind, f'/rigid_sim/{name}', qos_profile=SERVICE_QOS)
        self.spin_until(client.service_is_ready, READY_TIMEOUT)
        start = time.perf_counter()
        future = client.call_async(request)
        self.spin_until(future.done, timeout)
        return time.perf_counter() - start, future

    def spin_until(self, condition, timeout):
        """Spin until ``condition()`` or ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while not condition() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def close(self):
        """Destroy the client's node and shut its context down."""
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def _set_integrator(name):
    value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=name)
    return SetParameters.Request(parameters=[Parameter(name='integrator', value=value)])


def _start_work(client, work):
    """Start the state's work; its future (the step's answer) or None."""
    if work == 'step':
        return client.call(Trigger, 'step', Trigger.Request(), timeout=0.0)[1]
    if work == 'compile':
        client.call(SetParameters, 'set_parameters', _set_integrator('exact_split4'))
        time.sleep(1.0)   # well into the compile
    return None


def measure_state(client, scene, parameters, work, fresh_cache, log_dir):
    """(parameter call s, ~/pause s, stop s) of one node process in one state of work."""
    environment = dict(os.environ, ROS_LOG_DIR=log_dir)
    with tempfile.TemporaryDirectory() as cache:
        if fresh_cache:
            environment['NUMBA_CACHE_DIR'] = cache
        arguments = [f'scene:={scene}', *parameters]
        node = subprocess.Popen(
            [sys.executable, '-c', 'from rigid_sim import main; main.executable()',
             '--ros-args', *[part for argument in arguments for part in ('-p', argument)]],
            env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for kind, name, request in ((GetParameters, 'get_parameters', GetParameters.Request(
                    names=['rate'])), (SetBool, 'pause', SetBool.Request(data=False))):
                client.call(kind, name, request, READY_TIMEOUT)   # discovered, and answered
            if work == 'step':
                client.call(SetBool, 'pause', SetBool.Request(data=True))
            _start_work(client, work)
            asked = max(client.call(GetParameters, 'get_parameters',
                                    GetParameters.Request(names=['integrator']))[0]
                        for _ in range(SAMPLES))
            paused, _ = client.call(SetBool, 'pause', SetBool.Request(data=True))
            if work == 'step':   # the pause ended it: start another to stop in
                _start_work(client, work)
            signalled = time.perf_counter()
            node.send_signal(signal.SIGTERM)
            node.wait(EXIT_TIMEOUT)
            return asked, paused, time.perf_counter() - signalled
        finally:
            if node.poll() is None:
                node.kill()


def measure(scene, log_dir):
    """``[(state, parameter call s, pause s, stop s)]`` for every state of :data:`STATES`."""
    client = Client(int(os.environ['ROS_DOMAIN_ID']))
    try:
        return [(state, *measure_state(client, scene, parameters, work, fresh, log_dir))
                for state, parameters, work, fresh in STATES]
    finally:
        client.close()


def table(rows):
    """Markdown lines of the latency table, ms."""
    lines = ['| state | parameter call [ms] | ~/pause [ms] | SIGTERM to exit [ms] |',
             '| --- | --- | --- | --- |']
    lines += [f'| {state} | {1e3 * asked:.1f} | {1e3 * paused:.1f} | {1e3 * stop:.0f} |'
              for state, asked, paused, stop in rows]
    return lines
