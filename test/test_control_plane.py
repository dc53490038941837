# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Control apart from the work: the node answers while it steps, prepares and is signalled.

Nothing here is timed against a budget: each test checks an order of events that a blocked
executor cannot produce (a ``~/pause`` answered before the step it interrupts, ticks that go
on while a change is prepared, every call of a burst answered). The latencies themselves are
measured by ``rigid_sim_bench node`` (docs/performance.md).
"""
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

from diagnostic_msgs.msg import DiagnosticStatus
from rcl_interfaces.srv import GetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter
import processes
from ros_tools import spin_until
from std_srvs.srv import SetBool, Trigger

from rigid_sim.deferred import REQUEST_QUEUE_DEPTH, SERVICE_QOS
from rigid_sim.diagnostics_window import health, STALL_PERIODS, TickStats
from rigid_sim.executor import make_executor
from rigid_sim.node import RigidSimNode

BODIES = 'bodies:\n' + ''.join(
    f'  - {{name: b{i}, shape: {{type: box, size: [0.1, 0.2, 0.3]}}, mass: 1.0, '
    f'pose: {{position: [{i}.0, 0, 0]}}, twist: {{angular: [1.0, 2.0, 3.0]}}}}\n'
    for i in range(20))
LONG_STEP = 10_000   # ticks; with 50 substeps of 20 bodies, seconds of work


def call_async(sim, client_node, kind, name, request):
    """Send ``request`` to the simulator's service ``name``; the future of its answer."""
    client = client_node.create_client(kind, sim.topic(name), qos_profile=SERVICE_QOS)
    spin_until(sim.executor, client.service_is_ready, what=f'service {name}')
    return client.call_async(request)


def test_pause_is_answered_during_a_long_step_and_ends_it_saying_how_many_ticks_ran(rigid_sim):
    """A ``~/pause`` sent while a 10 000-tick step runs is answered, and ends the step.

    The step's answer counts the ticks that ran, fewer than asked (a step that blocked the
    executor would run all of them before the pause is even read), and the simulated time
    says the same.
    """
    sim = rigid_sim(yaml=BODIES, start_paused=True, step_ticks=LONG_STEP, substeps=50,
                    time_step=0.001)
    client = sim.create_node('client')
    step = call_async(sim, client, Trigger, 'step', Trigger.Request())
    spin_until(sim.executor, lambda: sim.node.ticks > 0, what='the step started')
    pause = call_async(sim, client, SetBool, 'pause', SetBool.Request(data=True))
    spin_until(sim.executor, pause.done, what='pause answered')
    spin_until(sim.executor, step.done, what='step answered')
    answer = step.result()
    ran = int(answer.message.split()[1])
    assert not answer.success and '~/pause' in answer.message
    assert 0 < ran < LONG_STEP
    assert abs(sim.time - ran * 0.001) < 1e-9


def test_a_burst_of_a_thousand_step_calls_is_answered_in_full(rigid_sim):
    """1000 ``~/step`` calls sent at once: 1000 answers, 1000 ticks of simulated time."""
    sim = rigid_sim(yaml=BODIES, start_paused=True, time_step=0.001)
    client = sim.create_node('client').create_client(Trigger, sim.topic('step'),
                                                     qos_profile=SERVICE_QOS)
    spin_until(sim.executor, client.service_is_ready, what='service step')
    calls = [client.call_async(Trigger.Request()) for _ in range(REQUEST_QUEUE_DEPTH)]
    spin_until(sim.executor, lambda: all(call.done() for call in calls),
               what='every step answered', timeout=120.0)
    assert all(call.result().success for call in calls)
    assert abs(sim.time - REQUEST_QUEUE_DEPTH * 0.001) < 1e-9


def test_step_calls_beyond_the_queue_bound_are_refused_saying_why(rigid_sim, monkeypatch):
    """Each waiting ``~/step`` holds an unanswered call: past the bound one is refused at once.

    Bound 3 here (1000 in the node): of five calls sent at once, three run their ticks and two
    are answered at once, refused, with the reason; the simulated time is three calls' worth.
    """
    monkeypatch.setattr('rigid_sim.tick_loop.MAX_QUEUED_JOBS', 3)
    sim = rigid_sim(yaml=BODIES, start_paused=True, time_step=0.001, step_ticks=200,
                    substeps=50)   # 0.2 million body-substeps a call: the calls queue
    client = sim.create_node('client').create_client(Trigger, sim.topic('step'),
                                                     qos_profile=SERVICE_QOS)
    spin_until(sim.executor, client.service_is_ready, what='service step')
    calls = [client.call_async(Trigger.Request()) for _ in range(5)]
    spin_until(sim.executor, lambda: all(call.done() for call in calls),
               what='every step answered', timeout=120.0)
    answers = [call.result() for call in calls]
    refused = [a.message for a in answers if not a.success]
    assert sum(a.success for a in answers) == 3 and len(refused) == 2
    assert all('refused: 3 step calls wait already, at most 3' in m for m in refused), refused
    assert abs(sim.time - 3 * 200 * 0.001) < 1e-9


def test_the_clock_and_parameters_go_on_while_a_change_is_prepared(
        rigid_sim_context, write_scene):
    """An integrator change whose preparation (compiling) blocks: ticks and calls go on.

    Once the preparation ends, the new integrator is swapped in between two ticks. The node
    runs on its own wall-clock loop here, which the test kit stops.
    """
    node = RigidSimNode(context=rigid_sim_context, parameter_overrides=[
        Parameter('scene', value=write_scene(BODIES)), Parameter('rate', value=200.0)])
    client = Node('client', context=rigid_sim_context)
    executor = make_executor(rigid_sim_context)
    executor.add_node(node)
    executor.add_node(client)
    try:
        _prepare_while_ticking(node, client, executor)
    finally:
        for each in (node, client):
            executor.remove_node(each)
            each.destroy_node()


def _prepare_while_ticking(node, client, executor):
    release = threading.Event()
    prepare = node.prepare

    def slow_prepare(settings, scene_changed):
        release.wait(60.0)   # a compile that takes as long as the test wants
        return prepare(settings, scene_changed)

    node.prepare = slow_prepare
    assert node.set_parameters([Parameter('integrator', value='rk4')])[0].successful
    ticks = node.ticks
    spin_until(executor, lambda: node.ticks > ticks + 20, what='ticks while preparing')
    asker = client.create_client(GetParameters, '/rigid_sim/get_parameters')
    spin_until(executor, asker.service_is_ready, what='parameter service')
    asked = asker.call_async(GetParameters.Request(names=['integrator']))
    spin_until(executor, asked.done, what='parameters answered while preparing')
    assert asked.result().values[0].string_value == 'rk4'
    assert node.world.integrator.name == 'exact_split'   # still the running one
    assert node.reconfiguration.preparing
    release.set()
    spin_until(executor, lambda: node.world.integrator.name == 'rk4',
               what='the prepared integrator swapped in')
    assert node.settings.integrator == 'rk4'


def test_diagnostics_are_an_error_when_no_tick_ran_for_two_periods():
    """A loop that stopped ticking is never reported OK, whatever its last window said."""
    period = 0.01
    level, summary = health(TickStats(0.0), period, 0, since_tick=(STALL_PERIODS + 1) * period)
    assert level == DiagnosticStatus.ERROR
    assert health(TickStats(0.0), period, 0, since_tick=period)[0] == DiagnosticStatus.OK
    assert 'no tick for' in summary
    assert health(TickStats(0.0), None, 0, since_tick=None)[1] == 'running'


# The node, as the console script starts it, with a preparation that holds the interpreter
# busy (as numba's typing does) until the process ends.
BUSY_PREPARATION = textwrap.dedent('''
    import sys
    from rclpy.parameter import Parameter
    from rigid_sim import main
    from rigid_sim.node import RigidSimNode

    def busy(self, settings, scene_changed):
        print('preparing', flush=True)
        while True:
            sum(range(1000))

    started = RigidSimNode.__init__

    def start_then_change(self, **kwargs):
        started(self, **kwargs)
        self.set_parameters([Parameter('integrator', value='rk4')])

    RigidSimNode.prepare = busy
    RigidSimNode.__init__ = start_then_change
    sys.argv = ['rigid_sim_node', '--ros-args', '-p', 'rate:=100.0']
    main.executable()
''')


def _node_process(code, tmp_path):
    environment = dict(os.environ, ROS_LOG_DIR=str(tmp_path))
    return processes.start([sys.executable, '-c', code], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, env=environment, text=True)


def test_a_stop_signal_during_a_runtime_preparation_ends_the_node_at_once(tmp_path):
    """SIGTERM while a change is prepared: status 0, no traceback, without waiting for it."""
    node = _node_process(BUSY_PREPARATION, tmp_path)
    for line in node.stdout:   # the node's start-up log, then the preparation's line
        if line == 'preparing\n':
            break
    time.sleep(0.5)   # well into the preparation
    node.send_signal(signal.SIGTERM)
    output, _ = node.communicate(timeout=10.0)   # the preparation alone would never end
    assert node.returncode == 0 and 'Traceback' not in output, output


STARTING_NODE = 'from rigid_sim import main; main.executable()'


def test_a_stop_signal_while_the_modules_import_ends_the_node_cleanly(tmp_path):
    """SIGINT or SIGTERM 0.2 s after exec, while rclpy, numba and scipy import: status 0."""
    for number in (signal.SIGINT, signal.SIGTERM):
        node = _node_process(STARTING_NODE, tmp_path)
        time.sleep(0.2)
        node.send_signal(number)
        output, _ = node.communicate(timeout=30.0)
        assert node.returncode == 0 and 'Traceback' not in output, (number, output)
