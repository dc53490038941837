# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Control latency of ``rigid_sim_node``: calls answered and signals obeyed while it works.

Part of ``rigid_sim_bench node``. The executable runs in its own process group, as a user
starts it; a client in this process, over DDS, times parameter calls (``get_parameters``,
one after another, 40 at least and until a spawn or GetEntitiesStates is answered or a
flood's 10 s are over: p50, p99 and the slowest) and a ``~/pause`` call from sending to
answer, and then the process's exit after SIGTERM (its status and how long it took), in
states of work: a 10 000-tick ``~/step`` of 1000 bodies, a runtime switch to an integrator
whose kernels are not in the (fresh) cache, overload (1000 bodies at rate 1000, more than
one core can tick), a goal on the springs scene, a flood of goals (150 Hz), 1000 substeps
a tick on 1000 bodies, dopri5 at tolerance 1e-12 on a rod spinning at 10 000 rad/s, a
GetEntitiesStates of 20 000 bodies (refused: more states than ``max_answer_states``) and
of 2000 (that bound's default), a spawn into a scene of 5000 bodies (one
SpawnEntity makes one entity; the swap carries all 5001), another process hearing every
topic of 1000 bodies (their pose, twist and odometry, the PoseArray, the markers and /tf;
sampled for 10 s once the last body's pose has come), an RViz-like process hearing
the markers, poses and /tf of 10 000 bodies at rate 30, and one hearing only their poses
(0.56 MB a tick; sampled for 10 s each). The node
promises each answer within 100 ms and each stop, with status 0, within 0.5 s. The machine's load
average over the run is given: other processes' load lengthens every number.
"""
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import namedtuple

import numpy as np
import rclpy
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters
from std_srvs.srv import SetBool, Trigger

from rigid_sim.deferred import SERVICE_QOS

READY_TIMEOUT = 600.0   # s; a cold start compiles, a 20 000-body scene loads
ANSWER_TIMEOUT = 60.0   # s
EXIT_TIMEOUT = 60.0     # s
SAMPLES = 40            # parameter calls per state, one after the other, at least
FLOOD_SECONDS = 10.0    # s of a flood of goals, sampled throughout
FLOOD_RATE = 150.0      # Hz of goals in the flood
# A thin rod (moments 1e-4, 1, 1.0001 kg m^2) spun at 10 000 rad/s about its middle axis.
FAST_ROD = """
bodies:
  - name: rod
    shape: {type: box, size: [0.999999995, 0.0099995, 0.0001]}
    mass: 12.0
    twist: {linear: [0.0, 0.0, 0.0], angular: [0.0, 10000.0, 10.0]}
    wrench_input: false
"""
# A client process that asks the simulator for every entity's state, says "sent", and
# waits for the answer.
STATES_CALLER = f"""
import os, rclpy
from simulation_interfaces.srv import GetEntitiesStates
from rigid_sim.deferred import SERVICE_QOS
rclpy.init(domain_id=int(os.environ['ROS_DOMAIN_ID']))
node = rclpy.create_node('states_caller')
client = node.create_client(GetEntitiesStates, '/rigid_sim/get_entities_states',
                            qos_profile=SERVICE_QOS)
client.wait_for_service({READY_TIMEOUT})
future = client.call_async(GetEntitiesStates.Request())
print('sent', flush=True)
rclpy.spin_until_future_complete(node, future, timeout_sec={ANSWER_TIMEOUT})
print(len(future.result().states) if future.done() else 'no answer', flush=True)
"""
# A client process that subscribes to every topic of the boxes_N scene's first N bodies
# (pose, twist and odometry each; N = 0: none, as RViz) and to ~/poses, ~/markers and /tf
# (second argument 'poses': ~/poses alone), says "heard" once the last body's pose (or two
# messages) has come, and takes what comes until it is killed.
HEARER = """
import os, sys, rclpy
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped
from nav_msgs.msg import Odometry
from visualization_msgs.msg import MarkerArray
from tf2_msgs.msg import TFMessage
from rigid_sim.tf_output import TF_QOS
bodies, aggregates = int(sys.argv[1]), sys.argv[2]
rclpy.init(domain_id=int(os.environ['ROS_DOMAIN_ID']))
node = rclpy.create_node('hearer')
heard = []
subscriptions = [node.create_subscription(kind, f'/rigid_sim/box{i}/{topic}', heard.append,
                                          1) for i in range(bodies) for kind, topic in
                 ((PoseStamped, 'pose'), (TwistStamped, 'twist'), (Odometry, 'odom'))]
for kind, topic, qos in ((PoseArray, '/rigid_sim/poses', 1),
                         (MarkerArray, '/rigid_sim/markers', 1), (TFMessage, '/tf', TF_QOS)):
    if aggregates == 'poses' and topic != '/rigid_sim/poses':
        continue
    subscriptions.append(node.create_subscription(kind, topic, heard.append, qos))
last = []   # the last body's pose; without per-body topics, the markers and /tf
if bodies:
    node.create_subscription(PoseStamped, f'/rigid_sim/box{bodies - 1}/pose', last.append, 1)
while not last if bodies else len(heard) < 2:
    rclpy.spin_once(node, timeout_sec=0.1)
print('heard', flush=True)
while True:
    rclpy.spin_once(node, timeout_sec=0.1)
    heard.clear()
"""
HEARD_BODIES = 1000
RVIZ_BODIES = 10_000   # bodies whose ~/markers, ~/poses and /tf an RViz-like client hears
HEARING = ('hear', 'rviz', 'poses')   # works of a hearer process, sampled FLOOD_SECONDS
# A state: its name, its scene ('boxes': the N boxes the caller gives, a scene file's
# name in the log directory, or a packaged one), node parameters, the work the client
# starts and whether the kernel cache starts empty.
State = namedtuple('State', 'name scene parameters work fresh_cache')
STATES = (
    State('long ~/step (1000 bodies, 10 000 ticks)', 'boxes_1000',
          ['rate:=0.0', 'start_paused:=true', 'step_ticks:=10000', 'substeps:=5'], 'step',
          False),
    State('runtime compile (switch to exact_split4, cache empty)', 'boxes_1000',
          ['rate:=100.0', 'integrator:=semi_implicit_euler'], 'compile', True),
    State('overload (1000 bodies at rate 1000)', 'boxes_1000', ['rate:=1000.0'], 'overload',
          False),
    State('a goal on the springs scene', 'springs.yaml', ['rate:=100.0'], 'goal', False),
    State(f'a goal flood ({FLOOD_RATE:g} Hz, springs scene)', 'springs.yaml', ['rate:=100.0'],
          'flood', False),
    State('substeps 1000 x 1000 bodies', 'boxes_1000', ['rate:=100.0', 'substeps:=1000'],
          'none', False),
    State('dopri5 at tolerance 1e-12 on a fast rod', 'fast_rod',
          ['rate:=100.0', 'integrator:=dopri5', 'tolerance:=1e-12'], 'none', False),
    State('GetEntitiesStates of 20 000 bodies (refused: above max_answer_states)',
          'boxes_20000', ['rate:=10.0'], 'states', False),
    State('GetEntitiesStates of 2000 bodies (max_answer_states, the default bound)',
          'boxes_2000', ['rate:=10.0'], 'states', False),
    State('spawn into 5000 bodies', 'boxes_5000', ['rate:=100.0'], 'spawn', False),
    State(f'every topic of {HEARD_BODIES} bodies heard (pose, twist, odom, ~/poses, '
          '~/markers, /tf)', f'boxes_{HEARD_BODIES}',
          ['rate:=100.0', f'per_body_topics_limit:={HEARD_BODIES}'], 'hear', False),
    State(f'RViz-like: ~/markers, ~/poses and /tf of {RVIZ_BODIES} bodies heard',
          f'boxes_{RVIZ_BODIES}', ['rate:=30.0'], 'rviz', False),
    State(f'~/poses of {RVIZ_BODIES} bodies heard (0.56 MB a tick)', f'boxes_{RVIZ_BODIES}',
          ['rate:=30.0'], 'poses', False),
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


def _goal(client, at=0.0):
    """Publish a goal for the springs scene's bob: 0.3 m up and aside, ``at`` (0: horizon)."""
    message = PoseStamped()
    message.header.frame_id = 'world'
    message.header.stamp.sec = int(at)
    message.pose.position.x, message.pose.position.y, message.pose.position.z = 0.6, -0.3, 0.9
    message.pose.orientation.w = 1.0
    client.goals.publish(message)


def _start_work(client, work, log_dir):
    """Start the state's work; its future (a deferred answer) or None."""
    if work == 'step':
        return client.call(Trigger, 'step', Trigger.Request(), timeout=0.0)[1]
    if work == 'compile':
        client.call(SetParameters, 'set_parameters', _set_integrator('exact_split4'))
        time.sleep(1.0)   # well into the compile
    if work in ('goal', 'flood'):
        client.goals = client.node.create_publisher(PoseStamped, '/rigid_sim/bob/goal', 10)
        client.spin_until(lambda: client.goals.get_subscription_count() > 0, READY_TIMEOUT)
        _goal(client)
        if work == 'flood':
            client.flood = client.node.create_timer(1.0 / FLOOD_RATE, lambda: _goal(client))
    if work == 'states':   # from another process: taking a big answer would slow this one
        client.caller = subprocess.Popen([sys.executable, '-c', STATES_CALLER],
                                         stdout=subprocess.PIPE, text=True)
        client.caller.stdout.readline()   # sent
        return None
    if work in HEARING:   # another process: taking them would slow this one
        bodies = HEARD_BODIES if work == 'hear' else 0
        client.caller = subprocess.Popen([sys.executable, '-c', HEARER, str(bodies), work],
                                         stdout=subprocess.PIPE, text=True)
        client.caller.stdout.readline()   # heard
        return None
    if work == 'spawn':
        from simulation_interfaces.srv import SpawnEntity
        request = SpawnEntity.Request(
            resource_string='{shape: {type: sphere, radius: 0.1}, mass: 1.0}',
            allow_renaming=True)
        return client.call(SpawnEntity, 'spawn_entity', request, timeout=0.0)[1]
    return None


def measure_state(client, scene, parameters, work, fresh_cache, log_dir):
    """(parameter call s samples, ~/pause s, exit status, stop s) of one node process."""
    environment = dict(os.environ, ROS_LOG_DIR=log_dir)
    with tempfile.TemporaryDirectory() as cache:
        if fresh_cache:
            environment['NUMBA_CACHE_DIR'] = cache
        arguments = [f'scene:={scene}', *parameters]
        node = subprocess.Popen(
            [sys.executable, '-c', 'from rigid_sim import main; main.executable()',
             '--ros-args', *[part for argument in arguments for part in ('-p', argument)]],
            env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True)
        try:
            for kind, name, request in ((GetParameters, 'get_parameters', GetParameters.Request(
                    names=['rate'])), (SetBool, 'pause', SetBool.Request(data=False))):
                client.call(kind, name, request, READY_TIMEOUT)   # discovered, and answered
            if work == 'step':
                client.call(SetBool, 'pause', SetBool.Request(data=True))
            answer = _start_work(client, work, log_dir)
            until = time.monotonic() + (FLOOD_SECONDS if work in ('flood', *HEARING)
                                        else ANSWER_TIMEOUT)
            busy = {'flood': lambda: True, **{hearing: lambda: True for hearing in HEARING},
                    'states': lambda: client.caller.poll() is None,
                    'spawn': lambda: not answer.done()}.get(work, lambda: False)
            asked = []   # SAMPLES at least, and while the work lasts
            while len(asked) < SAMPLES or (busy() and time.monotonic() < until):
                asked.append(client.call(GetParameters, 'get_parameters',
                                         GetParameters.Request(names=['integrator']))[0])
            paused, _ = client.call(SetBool, 'pause', SetBool.Request(data=True))
            if work == 'step':   # the pause ended it: start another to stop in
                _start_work(client, work, log_dir)
            signalled = time.perf_counter()
            node.send_signal(signal.SIGTERM)
            try:
                status = node.wait(EXIT_TIMEOUT)
            except subprocess.TimeoutExpired:
                status = None
            return asked, paused, status, time.perf_counter() - signalled
        finally:
            if getattr(client, 'flood', None) is not None:
                client.node.destroy_timer(client.flood)
                client.flood = None
            if getattr(client, 'caller', None) is not None:
                client.caller.kill()   # it has its answer by now, or it never will
                if work == 'states':
                    print(f'GetEntitiesStates answered with '
                          f'{client.caller.stdout.read().strip() or "no answer yet"} states',
                          file=sys.stderr)
                client.caller.wait()
                client.caller = None
            try:   # the node and anything it started
                os.killpg(node.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            node.wait()


def measure(scenes, log_dir, works=None):
    """``[(state, parameter call samples s, pause s, exit status, stop s)]`` per state.

    ``scenes``: scene name of :data:`STATES` -> file; a name not in it is used as it is.
    ``works``: only the states of these works (None: all).
    """
    client = Client(int(os.environ['ROS_DOMAIN_ID']))
    try:
        return [(state.name, *measure_state(client, scenes.get(state.scene, state.scene),
                                            state.parameters, state.work, state.fresh_cache,
                                            log_dir))
                for state in STATES if works is None or state.work in works]
    finally:
        client.close()


def table(rows):
    """Markdown lines of the latency table, ms."""
    lines = ['| state | parameter call p50 [ms] | p99 [ms] | slowest [ms] | ~/pause [ms] | '
             'exit status | SIGTERM to exit [ms] |', '| --- | --- | --- | --- | --- | --- | --- |']
    for state, asked, paused, status, stop in rows:
        p50, p99 = 1e3 * np.percentile(asked, [50, 99])
        lines.append(f'| {state} | {p50:.1f} | {p99:.1f} | {1e3 * max(asked):.1f} | '
                     f'{1e3 * paused:.1f} | '
                     f'{"none (killed)" if status is None else status} | {1e3 * stop:.0f} |')
    return lines
