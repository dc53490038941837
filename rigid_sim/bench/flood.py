# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench flood``: what a flood of wrench messages costs the node in real time.

The node runs in the executor ``rigid_sim_node`` runs (:mod:`rigid_sim.executor`), at
``rate`` 1 kHz with 1 ms steps, on one box taking wrenches. A flooding process
(:mod:`.flooder`) sends WrenchStamped to that box from several publishers. Windows with
and without the flood alternate within one run, so both see the same machine load; the
report gives the median real-time factor of each and their ratio.
"""
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import rclpy
from rclpy.parameter import Parameter

from rigid_sim import bench
from rigid_sim.bench.node_rate import ros_environment, spin_for
from rigid_sim.executor import make_executor
from rigid_sim.node import RigidSimNode

SECTION = 'rigid_sim_bench flood'
SCENE = """bodies:
  - {name: box, mass: 1.0, shape: {type: box, size: [0.2, 0.1, 0.05]}}
"""
RATE, TIME_STEP = 1000.0, 1e-3
FLOOD_RATE, PUBLISHERS = 10_000.0, 10
WINDOWS, WINDOW, SETTLE = 5, 2.0, 0.5   # pairs of windows, s each, s before each
QUICK = dict(windows=1, window=0.3, settle=0.2)


class Flooder:
    """The flooding process on ``topic``."""

    def __init__(self, topic, rate, publishers):
        self.process = subprocess.Popen(
            [sys.executable, '-m', 'rigid_sim.bench.flooder', topic, str(rate),
             str(publishers)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def command(self, word):
        """Send ``word`` (on, off, count); the number of messages sent so far."""
        self.process.stdin.write(word + '\n')
        self.process.stdin.flush()
        return int(self.process.stdout.readline())

    def stop(self):
        self.process.stdin.close()
        self.process.wait(timeout=10)


def window(executor, node, seconds):
    """Real-time factor and input messages the node took over ``seconds`` of spinning."""
    sim_start, wall_start = node.world.time, time.perf_counter()
    taken = node.inputs.received
    spin_for(executor, seconds)
    wall = time.perf_counter() - wall_start
    return (node.world.time - sim_start) / wall, (node.inputs.received - taken) / wall


def measure(context, scene, windows, seconds, settle):
    """Alternate flood-off and flood-on windows; the per-window results of each."""
    node = RigidSimNode(context=context, parameter_overrides=[
        Parameter('scene', value=scene), Parameter('rate', value=RATE),
        Parameter('time_step', value=TIME_STEP), Parameter('wrench_timeout', value=0.0)])
    executor = make_executor(context)
    executor.add_node(node)
    topic = f'{node.get_fully_qualified_name()}/box/wrench'
    flooder = Flooder(topic, FLOOD_RATE, PUBLISHERS)
    results = {'off': [], 'on': []}
    try:
        while node.count_publishers(topic) < PUBLISHERS:
            executor.spin_once(timeout_sec=0.05)
        for _ in range(windows):
            for state in ('off', 'on'):
                flooder.command(state)
                spin_for(executor, settle)
                sent = flooder.command('count')
                rtf, taken = window(executor, node, seconds)
                sent_rate = (flooder.command('count') - sent) / seconds
                results[state].append((rtf, taken, sent_rate))
        flooder.command('off')
        counts = (node.inputs.received, sum(node.inputs.refusals.superseded.values()), sum(
            node.inputs.refusals.counts.values()))
    finally:
        flooder.stop()
        executor.remove_node(node)
        node.destroy_node()
        executor.shutdown()
    return results, counts


def report(results, counts, seconds):
    """Return the Markdown section."""
    off = np.median([r[0] for r in results['off']])
    on = np.median([r[0] for r in results['on']])
    rows = [[state, len(results[state]), f'{np.median([r[0] for r in results[state]]):.3f}',
             f'{np.median([r[2] for r in results[state]]):.0f}',
             f'{np.median([r[1] for r in results[state]]):.0f}'] for state in ('off', 'on')]
    header = ['flood', 'windows', 'real-time factor (median)', 'sent [msg/s]',
              'taken by the node [msg/s]']
    return '\n'.join([
        '### Setup', *bench.machine_description(), f'- Command: `{bench.command_line()}`',
        f'- Node: rate {RATE:g} Hz, time_step {TIME_STEP:g} s, one box taking wrenches, in '
        'the executor `rigid_sim_node` runs (rclpy\'s EventsExecutor).',
        f'- Flood: {PUBLISHERS} publishers in another process, {FLOOD_RATE:g} msg/s in all, '
        "each a valid 1 N push with frame_id 'world' (so every one but the newest per tick "
        'is superseded).',
        f'- Windows of {seconds:g} s wall time, flood off and on alternating in one run.',
        '', bench.markdown_table(header, rows), '',
        f'Real-time factor with the flood / without: {on / off:.3f}. Over the run the node '
        f'took {counts[0]} wrench messages, {counts[1]} of them superseded (only the newest '
        f'per body and frame_id in a tick is applied), {counts[2]} refused.'])


def add_arguments(parser):
    """Options of ``rigid_sim_bench flood``."""
    parser.add_argument('--quick', action='store_true', help='one short pair of windows')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Run the windows, print the report, write ``--out``; the results."""
    chosen = QUICK if args.quick else dict(windows=WINDOWS, window=WINDOW, settle=SETTLE)
    with ros_environment() as log_dir:
        scene = Path(log_dir, 'flood.yaml')
        scene.write_text(SCENE)
        context = rclpy.Context()
        rclpy.init(context=context)
        try:
            results, counts = measure(context, str(scene), chosen['windows'],
                                      chosen['window'], chosen['settle'])
        finally:
            rclpy.try_shutdown(context=context)
    text = report(results, counts, chosen['window'])
    print(text)
    if args.out:
        bench.write_section(args.out, SECTION, text)
    return results
