# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench imu``: what an IMU costs per published reading, and what none costs.

The node (:class:`rigid_sim.node.RigidSimNode`, its own loop stopped) is ticked directly
on the boxes scene of ``rigid_sim_bench node`` in three variants: no IMU, an exact IMU on
every body, a noisy one (white noise and bias drift on both sensors) on every body. A
subscriber in the same process takes every IMU topic and the PoseArray, so each reading is
serialised and delivered as to a real user. The variants run interleaved in blocks of
ticks, in one run, and the cost of a reading is the difference of the median tick times
with and without IMUs over the IMUs read per tick.
"""
import sys
import time

import numpy as np
import rclpy
import yaml
from geometry_msgs.msg import PoseArray
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu

from rigid_sim import bench
from rigid_sim.bench.node_rate import ros_environment, scene_text
from rigid_sim.node import RigidSimNode

SECTION = 'rigid_sim_bench imu'
VARIANTS = {'none': None, 'exact': {'point': [0.05, 0.0, 0.0]},
            'noisy': {'point': [0.05, 0.0, 0.0], 'seed': 3,
                      'noise': {'gyro': {'stddev': 1e-3, 'dynamic_bias_stddev': 1e-4},
                                'accel': {'stddev': 1e-2, 'dynamic_bias_stddev': 1e-3}}}}
BODIES = (1, 100)
FULL = dict(blocks=20, ticks=200)
QUICK = dict(blocks=2, ticks=20)
TIME_STEP = 1e-3   # s, the 1 kHz physics of the node goals


def imu_scene(n, imu):
    """Write the boxes scene of N bodies with ``imu`` (a scene entry, or None) on every body."""
    scene = yaml.safe_load(scene_text(n))
    if imu is not None:
        for body in scene['bodies']:
            body['imu'] = imu
    return yaml.safe_dump(scene)


def start(context, folder, n, variant):
    """Start the node on the variant's scene, and a subscriber on its IMU topics and PoseArray."""
    path = f'{folder}/boxes_{n}_{variant}.yaml'
    with open(path, 'w', encoding='utf-8') as stream:
        stream.write(imu_scene(n, VARIANTS[variant]))
    node = RigidSimNode(context=context, parameter_overrides=[
        Parameter('scene', value=path), Parameter('time_step', value=TIME_STEP),
        Parameter('rate', value=1000.0), Parameter('integrator', value='rk4')])
    node.loop.stop()
    listener = rclpy.create_node(f'imu_listener_{n}_{variant}', context=context)
    prefix = node.get_fully_qualified_name()
    listener.create_subscription(PoseArray, f'{prefix}/poses', lambda _: None, 10, raw=True)
    if VARIANTS[variant] is not None:
        for body in node.scene.bodies:
            listener.create_subscription(Imu, f'{prefix}/{body.name}/imu', lambda _: None, 10,
                                         raw=True)
    return node, listener


def measure(context, folder, n, blocks, ticks):
    """Median tick time (s) of every variant at N bodies, interleaved in ``blocks``."""
    runs = {variant: start(context, folder, n, variant) for variant in VARIANTS}
    times = {variant: [] for variant in VARIANTS}
    try:
        for node, _ in runs.values():   # warm up, and let every node see its subscribers
            for _ in range(ticks):
                node.tick()
        for _ in range(blocks):
            for variant, (node, _) in runs.items():
                for _ in range(ticks):
                    started = time.perf_counter()
                    node.tick()
                    times[variant].append(time.perf_counter() - started)
    finally:
        for node, listener in runs.values():
            node.destroy_node()
            listener.destroy_node()
    return {variant: float(np.median(values)) for variant, values in times.items()}


def table(results):
    """Markdown: median tick per variant and the cost per reading."""
    header = ['N', 'tick, no IMU [us]', 'tick, exact IMUs [us]', 'tick, noisy IMUs [us]',
              'per exact reading [us]', 'per noisy reading [us]']
    rows = []
    for n, medians in results.items():
        base = medians['none']
        rows.append([n] + [f'{1e6 * medians[v]:.1f}' for v in VARIANTS]
                    + [f'{1e6 * (medians[v] - base) / n:.1f}' for v in ('exact', 'noisy')])
    return bench.markdown_table(header, rows)


def add_arguments(parser):
    """Options of ``rigid_sim_bench imu``."""
    parser.add_argument('--quick', action='store_true', help='a few ticks only, for tests')
    parser.add_argument('--out', help='Markdown file whose section is (re)written')


def main(args):
    """Measure, print the Markdown report, write ``--out``; the results."""
    chosen = QUICK if args.quick else FULL
    results = {}
    with ros_environment() as folder:
        context = rclpy.Context()
        rclpy.init(context=context)
        try:
            for n in BODIES:
                results[n] = measure(context, folder, n, **chosen)
                print(f'N = {n}: {results[n]}', file=sys.stderr)
        finally:
            rclpy.try_shutdown(context=context)
    machine = [line for line in bench.machine_description()
               if not line.startswith('- CPU time')]
    text = '\n'.join([
        '### Setup', *machine, f'- Command: `{bench.command_line()}`',
        f'- {chosen["blocks"]} blocks of {chosen["ticks"]} ticks per variant, interleaved; '
        f'`time.perf_counter` around `tick()`, median; rk4, time_step {TIME_STEP:g} s; '
        'every tick reads every IMU (no IMU rate) and publishes the PoseArray.',
        '', '### Tick time with and without IMUs', table(results)])
    print(text)
    if args.out is not None:
        bench.write_section(args.out, SECTION, text)
    return results
