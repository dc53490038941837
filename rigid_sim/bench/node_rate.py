# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench node``: the node at scale, real-time factor and tick time against N.

The node (:class:`rigid_sim.node.RigidSimNode`, every tick timed) spins in the
executor ``rigid_sim_node`` runs (:mod:`rigid_sim.executor`), on a scene of N boxes under gravity,
each with its own spin, and on the packaged default scene, whose share of a core it costs
is a goal of its own. A listener in another process (:mod:`.node_listener`) subscribes to
exactly the topics a configuration claims to publish and counts what arrives: the node only
fills and sends outputs that have subscribers, so without it publishing would cost nothing.
Timing starts once every claimed topic is matched and after a warm-up.
"""
import contextlib
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import namedtuple
from pathlib import Path

import numpy as np
import rclpy
import yaml
from rclpy.parameter import Parameter

import rigid_sim
from rigid_sim import bench
from rigid_sim.bench import control_latency
from rigid_sim.core.integrators import DEFAULT_INTEGRATOR, REGISTRY
from rigid_sim.executor import freeze_long_lived_objects, make_executor
from rigid_sim.node import RigidSimNode
from rigid_sim.resources import find_scene

SECTION = 'rigid_sim_bench node'
CONTROL_SECTION = 'rigid_sim_bench node: control latency'
WRENCH_INPUT_LIMIT = 100   # from this N on, no wrench subscriptions (see the module text)
MATCH_TIMEOUT = 30.0       # s; discovery takes seconds, more with thousands of endpoints
STOP_TIMEOUT = 5.0         # s the listener gets to exit after SIGINT
GOAL_RTF = 0.99            # a 1 kHz wall-clock timer cannot average above 1; see the report
DURATION, WARMUP = 5.0, 1.0   # s of wall time


# N bodies, rate [Hz], time_step [s], substeps, publish_rate [Hz], what the listener
# takes ('bodies': pose and twist of every body, 'poses': the PoseArray, 'clock': /clock,
# 'nothing') and the scene ('boxes' of N bodies, or 'default.yaml', the packaged one).
Config = namedtuple('Config', 'bodies rate time_step substeps publish_rate listened scene',
                    defaults=('boxes',))
DEFAULT_SCENE = 'default.yaml'
CONFIGS = (Config(2, 100.0, 1e-2, 1, 100.0, 'nothing', DEFAULT_SCENE),
           Config(2, 100.0, 1e-2, 1, 100.0, 'clock', DEFAULT_SCENE),
           Config(2, 1000.0, 1e-3, 1, 1000.0, 'nothing', DEFAULT_SCENE),
           Config(1, 1000.0, 1e-3, 1, 100.0, 'bodies'),
           Config(100, 1000.0, 1e-3, 1, 100.0, 'bodies'),
           Config(100, 100.0, 1e-2, 10, 100.0, 'bodies'),
           Config(1000, 1000.0, 1e-3, 1, 50.0, 'poses'),
           Config(1000, 50.0, 2e-2, 20, 50.0, 'poses'),
           # 20 ms steps, split only where the World's step control asks: no 1 kHz physics,
           # so no goal counts it; exact_split moves these torque-free boxes exactly anyway.
           Config(1000, 50.0, 2e-2, 1, 50.0, 'poses'))
QUICK = dict(configs=(Config(1, 1000.0, 1e-3, 1, 100.0, 'bodies'),
                      Config(10, 100.0, 1e-2, 10, 100.0, 'poses'),
                      Config(2, 100.0, 1e-2, 1, 100.0, 'clock', DEFAULT_SCENE)),
             duration=0.5, warmup=0.3, start_sizes=(10,), control=False)
# Scenes (N bodies, every one taking wrenches) the executable is started and stopped on.
START_SIZES = (1000, 10_000)
START_TIMEOUT = 120.0   # s
# The node's real-time goals: (N, what is listened, wording), all with 1 kHz physics.
GOAL_PHYSICS_STEP = 1e-3   # s
GOALS = ((100, 'bodies', '100 bodies, per-body pose and twist at 100 Hz, 1 kHz physics'),
         (1000, 'poses', '1000 bodies, PoseArray at 50 Hz, 1 kHz physics'))
# The default scene, nobody listening: at rate 100 under this share of a core with ticks
# (p99) under this many seconds; at rate 1000 the real-time goal above.
GOAL_CORE_SHARE, GOAL_TICK_P99 = 0.05, 5e-4


class TimedNode(RigidSimNode):
    """A RigidSimNode that records the wall time of every tick (s, publishing included)."""

    def __init__(self, **kwargs):
        self.tick_seconds = []
        super().__init__(**kwargs)   # its tick loop calls self._tick: the method below

    def _tick(self, advance, until=None):
        started = time.perf_counter()
        done = super()._tick(advance, until)
        self.tick_seconds.append(time.perf_counter() - started)
        return done


def scene_text(n, wrench_input=None):
    """YAML of N boxes (1 kg) in a grid 0.5 m apart under gravity, each with its own spin.

    ``wrench_input`` None: only below WRENCH_INPUT_LIMIT bodies.
    """
    side = math.ceil(math.sqrt(n))
    spins = np.random.default_rng(n).normal(scale=2.0, size=(n, 3))   # rad/s
    bodies = [{'name': f'box{i}', 'shape': {'type': 'box', 'size': [0.2, 0.1, 0.05]},
               'mass': 1.0, 'pose': {'position': [0.5 * (i % side), 0.5 * (i // side), 1.0]},
               'twist': {'angular': spins[i].tolist()},
               'wrench_input': n < WRENCH_INPUT_LIMIT if wrench_input is None
               else wrench_input} for i in range(n)]
    return yaml.safe_dump({'world_frame': 'world',
                           'effects': {'gravity': {'acceleration': [0.0, 0.0, -9.81]}},
                           'bodies': bodies})


def claimed_topics(node, config):
    """Absolute names of the topics ``config`` listens to."""
    prefix = node.get_fully_qualified_name()
    if config.listened in ('clock', 'nothing'):
        return ['/clock'] if config.listened == 'clock' else []
    if config.listened == 'poses':
        return [f'{prefix}/poses']
    return [f'{prefix}/{body.name}/{kind}' for body in node.scene.bodies
            for kind in ('pose', 'twist')]


@contextlib.contextmanager
def ros_environment():
    """Set this run's ROS settings in ``os.environ`` (restored on exit); yield the log dir."""
    saved = dict(os.environ)
    log_dir = tempfile.mkdtemp(prefix='rigid_sim_bench_node_')
    for deprecated_or_widening in ('ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS'):
        os.environ.pop(deprecated_or_widening, None)
    os.environ.update(ROS_DOMAIN_ID=str(1 + os.getpid() % 101),   # 1..101: valid on Linux
                      ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_LOG_DIR=log_dir)
    try:
        yield log_dir
    finally:
        os.environ.clear()
        os.environ.update(saved)
        shutil.rmtree(log_dir, ignore_errors=True)


class Listener:
    """The counting process (:mod:`.node_listener`) on ``topics``; log file in ``log_dir``."""

    def __init__(self, topics, log_dir):
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [str(Path(rigid_sim.__file__).parents[1]), os.environ.get('PYTHONPATH', '')]))
        self.log = Path(log_dir, 'listener.log')
        with self.log.open('w') as log:
            self.process = subprocess.Popen(
                [sys.executable, '-m', 'rigid_sim.bench.node_listener', *topics],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log, env=env, text=True)

    def counts(self):
        """``{topic: messages received so far}``."""
        self.process.stdin.write('\n')
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f'the listener exited: {self.log.read_text()[-2000:]}')
        return yaml.safe_load(line)   # JSON is YAML

    def stop(self):
        """SIGINT, then kill if it has not exited within STOP_TIMEOUT."""
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.process.stdin.close()
        self.process.stdout.close()


def spin_for(executor, seconds):
    """Spin ``executor`` for ``seconds`` of wall time."""
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline:
        executor.spin_once(timeout_sec=0.01)


def wait_matched(executor, node, topics):
    """Spin until every topic in ``topics`` has a subscriber; RuntimeError after a timeout."""
    deadline = time.monotonic() + MATCH_TIMEOUT
    while not all(node.count_subscribers(topic) >= 1 for topic in topics):
        if time.monotonic() > deadline:
            raise RuntimeError(f'the listener did not match within {MATCH_TIMEOUT} s')
        executor.spin_once(timeout_sec=0.05)


def measure(config, integrator, context, scene, log_dir, seconds):
    """Run ``config`` with ``integrator`` on the scene file ``scene``; a result dict.

    ``seconds`` is (warm-up, timed) wall time. Ticks, simulated time and messages count
    only in the timed window, which starts once the listener is matched and warmed up.
    """
    values = dict(scene=scene, rate=config.rate, time_step=config.time_step,
                  substeps=config.substeps, publish_rate=config.publish_rate,
                  integrator=integrator)
    node = TimedNode(context=context, parameter_overrides=[
        Parameter(name, value=value) for name, value in values.items()])
    freeze_long_lived_objects()   # as rigid_sim_node does before it spins
    executor = make_executor(context)   # as rigid_sim_node runs it
    executor.add_node(node)
    topics = claimed_topics(node, config)
    waitables = len(list(node.waitables))   # what a Python executor's round would collect
    listener = Listener(topics, log_dir)
    try:
        wait_matched(executor, node, topics)
        spin_for(executor, seconds[0])   # also lets the node notice its subscribers
        before = listener.counts()
        node.tick_seconds.clear()
        sim_start, wall_start = node.world.time, time.perf_counter()
        cpu_start = time.process_time()   # every thread of the process: the middleware's too
        spin_for(executor, seconds[1])
        cpu = time.process_time() - cpu_start
        wall = time.perf_counter() - wall_start
        simulated, ticks = node.world.time - sim_start, np.array(node.tick_seconds)
        after = listener.counts()
    finally:
        listener.stop()
        executor.remove_node(node)
        node.destroy_node()
        executor.shutdown()
    received = np.array([after[topic] - before[topic] for topic in topics])
    return dict(config=config, integrator=integrator, real_time_factor=simulated / wall,
                tick_mean=ticks.mean(), tick_p50=np.percentile(ticks, 50),
                tick_p99=np.percentile(ticks, 99), core_share=cpu / wall,
                busy=ticks.sum() / wall, ticks=len(ticks), expected_ticks=config.rate * wall,
                received_rate=received.sum() / wall,
                expected_rate=config.publish_rate * len(topics),
                topics_heard=int(np.count_nonzero(received)), topics=len(topics),
                waitables=waitables)


def start_and_stop(scene, log_dir):
    """Start ``rigid_sim_node`` on ``scene``, then SIGINT it: (start s, stop s, exit status).

    Start: from the process's creation to its log line saying it simulates (imports, scene
    loading and wiring; its first tick follows). Stop: from SIGINT to the process's end.
    """
    executable = Path(sys.executable).with_name('rigid_sim_node')
    started = time.perf_counter()
    process = subprocess.Popen(
        [str(executable), '--ros-args', '-p', f'scene:={scene}', '-r', '__ns:=/bench_start'],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=log_dir)
    try:
        for line in process.stdout:
            if 'simulating' in line:
                break
        start = time.perf_counter() - started
        time.sleep(0.5)   # a few ticks
        signalled = time.perf_counter()
        process.send_signal(signal.SIGINT)
        status = process.wait(START_TIMEOUT)
        return start, time.perf_counter() - signalled, status
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        process.stdout.close()


def start_table(starts):
    """Markdown: a row per scene size the executable was started on."""
    rows = [[n, f'{start:.2f}', f'{stop:.3f}', status] for n, (start, stop, status) in starts]
    return bench.markdown_table(['N (all taking wrenches)', 'start [s]', 'stop after SIGINT [s]',
                                 'exit status'], rows)


def table(results):
    """Markdown: a row per configuration and integrator."""
    header = ['N', 'scene', 'integrator', 'rate [Hz] x substeps', 'time_step [s]', 'listened',
              'real-time factor', 'CPU [% of a core]', 'tick mean [ms]', 'tick p50 [ms]',
              'tick p99 [ms]', 'busy', 'ticks / expected', 'received / expected [msg/s]',
              'topics heard', 'waitables']
    listened = {'bodies': 'pose + twist of each body', 'poses': '~/poses', 'clock': '/clock',
                'nothing': 'nothing'}
    rows = [[r['config'].bodies, r['config'].scene, r['integrator'],
             f'{r["config"].rate:g} x {r["config"].substeps}', f'{r["config"].time_step:g}',
             listened[r['config'].listened]
             + (f' at {r["config"].publish_rate:g} Hz' if r['topics'] else ''),
             f'{r["real_time_factor"]:.3f}', f'{100 * r["core_share"]:.2f}',
             f'{1e3 * r["tick_mean"]:.3g}', f'{1e3 * r["tick_p50"]:.3g}',
             f'{1e3 * r["tick_p99"]:.3g}', f'{100 * r["busy"]:.0f} %',
             f'{r["ticks"]} / {r["expected_ticks"]:.0f}',
             f'{r["received_rate"]:.0f} / {r["expected_rate"]:.0f}',
             f'{r["topics_heard"]} / {r["topics"]}', r['waitables']] for r in results]
    return bench.markdown_table(header, rows)


def physics_step(config):
    """Return the step the integrator is given, s (the World may split it further)."""
    return config.time_step / config.substeps


def goals(results):
    """Return Markdown lines: each real-time goal, met or not, with the numbers."""
    lines = []
    for bodies, listened, wording in GOALS:
        runs = [r for r in results
                if (r['config'].bodies, r['config'].listened) == (bodies, listened)
                and physics_step(r['config']) <= GOAL_PHYSICS_STEP * (1 + 1e-9)]
        if not runs:
            continue
        verdicts = [f'{"met" if r["real_time_factor"] >= GOAL_RTF else "NOT met"} by '
                    f'{r["integrator"]} at {r["config"].rate:g} Hz x {r["config"].substeps} '
                    f'substeps (real-time factor {r["real_time_factor"]:.3f}, mean tick '
                    f'{1e3 * r["tick_mean"]:.2f} ms, {r["received_rate"]:.0f} of '
                    f'{r["expected_rate"]:.0f} msg/s received)' for r in runs]
        lines.append(f'- {wording}: ' + '; '.join(verdicts) + '.')
    return lines + default_scene_goals(results)


def default_scene_goals(results):
    """Markdown lines: the default scene's share of a core at rate 100, its rate at 1000."""
    lines = []
    for r in results:
        config = r['config']
        if (config.scene, config.listened) != (DEFAULT_SCENE, 'nothing'):
            continue
        if config.rate == 100.0:
            met = r['core_share'] < GOAL_CORE_SHARE and r['tick_p99'] < GOAL_TICK_P99
            lines.append(f'- The default scene at 100 Hz under {100 * GOAL_CORE_SHARE:g} % of '
                         f'a core, tick p99 under {1e3 * GOAL_TICK_P99:g} ms: '
                         f'{"met" if met else "NOT met"} by {r["integrator"]} '
                         f'({100 * r["core_share"]:.2f} %, p99 {1e3 * r["tick_p99"]:.2f} ms).')
        elif config.rate == 1000.0:
            met = r['real_time_factor'] >= GOAL_RTF
            lines.append(f'- The default scene at 1000 Hz: {"met" if met else "NOT met"} by '
                         f'{r["integrator"]} (real-time factor {r["real_time_factor"]:.3f}).')
    return lines


def report(results, seconds, starts=()):
    """Return the Markdown section: how it was measured, the tables, the goals."""
    machine = [line for line in bench.machine_description()
               if not line.startswith('- CPU time')]   # this benchmark times wall clock
    return '\n'.join([
        '### Setup', *machine, f'- Command: `{bench.command_line()}`',
        f'- Wall time (`time.perf_counter`): {seconds[1]:g} s timed per row after the '
        f'listener matched and {seconds[0]:g} s of warm-up.',
        '- Scene: N boxes (1 kg, 0.2 x 0.1 x 0.05 m) in a grid under gravity, each with its '
        f'own spin; from N = {WRENCH_INPUT_LIMIT} on `wrench_input: false`, so the executor '
        'does not wait on N wrench subscriptions (~625 callbacks/s with 100 of them); or the '
        f'packaged `{DEFAULT_SCENE}` (2 bodies, gravity, damping, two springs).',
        '- CPU: `time.process_time` of the whole process (the middleware\'s threads too) over '
        'the timed wall time.',
        '- The node runs in one EventsExecutor, in one thread, as `rigid_sim_node` '
        'does; `/clock` goes out every tick it has a subscriber (default). A listener process '
        '(the second core) subscribes to exactly the topics in "listened" and counts what '
        'arrives; the node fills and sends only outputs with subscribers.',
        '- Tick: applying inputs, integrating and publishing (`time.perf_counter` around '
        '`tick()`). Busy: the share of wall time spent in ticks. Real-time factor: simulated '
        'time advanced over wall time; the tick loop catches late ticks up and gives up '
        'those more than 0.1 s behind (`rigid_sim/tick_loop.py`).',
        '- Waitables: entities of the node (such as the QoS event handlers rclpy gives every '
        'publisher) that a Python executor adds to its wait set on every round; the '
        'EventsExecutor does not rebuild a wait set.',
        '', '### Real-time factor and tick time', table(results),
        '', '### Start and stop of the executable',
        '`rigid_sim_node` on a scene of N boxes that all take wrenches, default parameters '
        '(per-body topics made on demand above `per_body_topics_limit`). Start: process '
        'creation to the log line that it simulates; stop: SIGINT to the end of the process.',
        '', start_table(starts),
        '', f'### Real-time goals with 1 kHz physics (met: real-time factor >= {GOAL_RTF}; a '
        'wall-clock timer '
        'cannot average above 1, and window edges move it by ~1e-3; only rows whose '
        f'integrator steps are <= {1e3 * GOAL_PHYSICS_STEP:g} ms count as 1 kHz physics)',
        *goals(results)])


def control_report(rows, load=None):
    """Return the control-latency section: how it was measured and the table.

    ``load``: the machine's 1-minute load average at the start and the end of the run.
    """
    machine = [line for line in bench.machine_description()
               if not line.startswith('- CPU time')]
    if load is not None:
        machine.append(f'- Load average (1 min) at the start and the end: {load[0]:.1f}, '
                       f'{load[1]:.1f}')
    return '\n'.join([
        '### Control latency while the node works (promise: answers within 100 ms, a stop '
        'within 0.5 s)', *machine, f'- Command: `{bench.command_line()}`',
        '- ' + control_latency.__doc__.split('\n\n')[1].replace('\n', ' '), '',
        *control_latency.table(rows)])


def add_arguments(parser):
    """Options of ``rigid_sim_bench node``."""
    parser.add_argument('--quick', action='store_true',
                        help='tiny configuration (N = 1 and 10, 0.5 s each) for tests')
    parser.add_argument('--integrators', nargs='+', choices=sorted(REGISTRY),
                        default=[DEFAULT_INTEGRATOR],
                        help=f'integrators to run each configuration with '
                             f'(default {DEFAULT_INTEGRATOR})')
    parser.add_argument('--duration', type=float, help=f'timed s per row (default {DURATION})')
    parser.add_argument('--warmup', type=float, help=f'warm-up s per row (default {WARMUP})')
    parser.add_argument('--no-control', dest='control', action='store_false',
                        help='skip the control-latency rows (not run with --quick either)')
    parser.add_argument('--control-only', action='store_true',
                        help='only the control-latency rows')
    parser.add_argument('--control-works', nargs='+',
                        choices=sorted({state.work for state in control_latency.STATES}),
                        help='only the control-latency states of these works (default all)')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Run every configuration, print the Markdown report, write ``--out``; the results."""
    chosen = QUICK if args.quick else dict(configs=CONFIGS, duration=DURATION, warmup=WARMUP,
                                           start_sizes=START_SIZES)
    seconds = (chosen['warmup'] if args.warmup is None else args.warmup,
               chosen['duration'] if args.duration is None else args.duration)
    results, starts = [], []
    domain = os.environ.get('ROS_DOMAIN_ID')
    with ros_environment() as log_dir:
        if domain:   # the caller's own domain, if it chose one
            os.environ['ROS_DOMAIN_ID'] = domain
        if not args.control_only:
            results = run_configurations(chosen['configs'], args.integrators, log_dir, seconds)
            starts = run_starts(chosen['start_sizes'], log_dir)
        if chosen.get('control', True) and args.control:
            scenes = {}
            for n in (1000, 2000, control_latency.HEARD_BODIES, 5000, 20_000):
                scenes[f'boxes_{n}'] = str(Path(log_dir, f'boxes_{n}.yaml'))
                Path(scenes[f'boxes_{n}']).write_text(scene_text(n))
            scenes['fast_rod'] = str(Path(log_dir, 'fast_rod.yaml'))
            Path(scenes['fast_rod']).write_text(control_latency.FAST_ROD)
            load = os.getloadavg()[0]
            rows = control_latency.measure(scenes, log_dir, args.control_works)
            write(args.out, CONTROL_SECTION, control_report(rows, (load, os.getloadavg()[0])))
    if not args.control_only:
        write(args.out, SECTION, report(results, seconds, starts))
    return results


def write(out, section, text):
    """Print ``text`` and make it ``section`` of the file ``out`` (when given)."""
    print(text)
    if out is not None:
        bench.write_section(out, section, text)


def run_configurations(configs, integrators, log_dir, seconds):
    """Measure every configuration with every integrator, in one rclpy context."""
    results = []
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(os.environ['ROS_DOMAIN_ID']))
    try:
        for config in configs:
            scene = Path(log_dir, f'boxes_{config.bodies}.yaml')
            if config.scene == DEFAULT_SCENE:
                scene = find_scene(DEFAULT_SCENE)
            else:
                scene.write_text(scene_text(config.bodies))
            for integrator in integrators:
                results.append(measure(config, integrator, context, str(scene), log_dir,
                                       seconds))
                print(f'{config} {integrator}: real-time factor '
                      f'{results[-1]["real_time_factor"]:.3f}', file=sys.stderr)
    finally:
        rclpy.try_shutdown(context=context)
    return results


def run_starts(sizes, log_dir):
    """Start and stop the executable on a scene of each size; [(N, (start s, stop s))]."""
    starts = []
    for n in sizes:
        scene = Path(log_dir, f'wrenched_{n}.yaml')
        scene.write_text(scene_text(n, wrench_input=True))
        starts.append((n, start_and_stop(str(scene), log_dir)))
        print(f'start and stop at N = {n}: {starts[-1][1]}', file=sys.stderr)
    return starts
