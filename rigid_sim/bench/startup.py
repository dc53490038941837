# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench startup``: process start to the first ``World.step``, cold and cached.

A fresh Python process loads a scene (by default each packaged one) and steps it once, for
each integrator asked. *Cold* runs with an empty numba cache directory (``NUMBA_CACHE_DIR``), so
every kernel that step uses is compiled; *cached* runs again with the same directory, so
they are loaded from disk. Wall time of the whole process (interpreter start included), its
CPU time, and the compile time :func:`rigid_sim.core.warm_up.warm_up` reports inside it.
Then the node itself, cold: a ``rigid_sim_node`` process's start to its first tick
(:mod:`.first_tick`). On a shared machine wall times grow with the others' load (reported);
the cold process's CPU time is close to what its wall time would be on an idle machine.
"""
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rigid_sim import bench
from rigid_sim.bench import first_tick, node_rate
from rigid_sim.core.integrators import DEFAULT_INTEGRATOR
from rigid_sim.resources import DEFAULT_SCENE, find_scene

SECTION = 'rigid_sim_bench startup'
REPEATS = 1
# The child: load the scene, warm up (its IMUs too), step once; prints the warm-up seconds
# and the kernels it compiled.
CHILD = '''
from rigid_sim.core.imu import scene_imus
from rigid_sim.core.scene import build_world, load_scene
from rigid_sim.core.warm_up import warm_up_reporting
from rigid_sim.resources import find_scene
scene = load_scene(find_scene({scene!r}))
world = build_world(scene, {integrator!r})
seconds, compiled = warm_up_reporting(world, imus=scene_imus(scene, world))
assert world.step(0.01)
print(seconds, compiled)
'''


def packaged_scenes():
    """File names of the scenes shipped in ``config/scenes``."""
    return sorted(path.name for path in Path(find_scene(DEFAULT_SCENE)).parent.glob('*.yaml'))


def _children_cpu():
    """CPU seconds (user and system) of the waited-for child processes so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def start_once(scene, integrator, cache_dir):
    """One child process: (wall s, CPU s, compile s reported, kernels compiled)."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    start, cpu = time.perf_counter(), _children_cpu()
    done = subprocess.run([sys.executable, '-c', CHILD.format(scene=scene,
                                                              integrator=integrator)],
                          env=environment, capture_output=True, text=True, check=True)
    seconds, compiled = done.stdout.split()[-2:]
    return (time.perf_counter() - start, _children_cpu() - cpu, float(seconds),
            int(compiled))


def measure(scenes, integrators, repeats, log_dir):
    """``{(scene, integrator): (cold, cached, node)}``: medians of ``repeats`` starts.

    ``cold`` and ``cached`` are :func:`start_once`'s, ``node`` the seconds to a cold node's
    first tick; every cold start has an empty cache of its own.
    """
    results = {}
    for scene in scenes:
        for integrator in integrators:
            cold, cached, node = [], [], []
            for _ in range(repeats):
                with tempfile.TemporaryDirectory() as cache_dir:
                    cold.append(start_once(scene, integrator, Path(cache_dir)))
                    cached.append(start_once(scene, integrator, Path(cache_dir)))
                with tempfile.TemporaryDirectory() as cache_dir:
                    node.append(first_tick.first_clock(scene, integrator, cache_dir, log_dir))
            results[scene, integrator] = tuple(sorted(runs)[len(runs) // 2]
                                               for runs in (cold, cached, node))
    return results


def report(results, others):
    """Format the Markdown section: setup and one row per scene and integrator.

    ``others`` is the fraction of the cores' time other processes used meanwhile.
    """
    rows = [[scene, name, str(cold[3]), f'{cold[0]:.2f}', f'{cold[1]:.2f}', f'{cold[2]:.2f}',
             f'{cached[0]:.2f}', f'{cached[2]:.2f}', f'{node:.2f}']
            for (scene, name), (cold, cached, node) in results.items()]
    machine = [line for line in bench.machine_description() if 'CPU time' not in line]
    return '\n'.join(['### Setup', *machine,
                      f'- Command: `{bench.command_line()}`',
                      f'- Other processes kept the cores {100.0 * others:.0f} % busy during the '
                      'run (/proc/stat, less this run\'s own processes)',
                      '- Process: a fresh Python process that imports the core, loads the '
                      'scene, warms up and steps once (wall and CPU time); kernels: the '
                      'specialisations its cold start compiled; node: `rigid_sim_node` started '
                      'with an empty cache, to its first /clock',
                      '', '### Start-up [s] (median of the repeats)',
                      bench.markdown_table(['scene', 'integrator', 'kernels', 'cold: process',
                                            'cold: process CPU', 'cold: compile',
                                            'cached: process', 'cached: load',
                                            'node, cold: first tick'], rows)])


def add_arguments(parser):
    """Options of ``rigid_sim_bench startup``."""
    parser.add_argument('--scenes', nargs='+', help='scene files (default: every packaged one)')
    parser.add_argument('--integrators', nargs='+', default=[DEFAULT_INTEGRATOR],
                        help='integrators to start with')
    parser.add_argument('--repeats', type=int, default=REPEATS, help='starts per setting')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Run the benchmark, print the Markdown report and write ``--out``."""
    domain = os.environ.get('ROS_DOMAIN_ID')
    with node_rate.ros_environment() as log_dir:
        if domain:   # the caller's own domain, if it chose one
            os.environ['ROS_DOMAIN_ID'] = domain
        others = first_tick.OtherLoad()
        results = measure(args.scenes or packaged_scenes(), args.integrators, args.repeats,
                          log_dir)
    text = report(results, others.fraction())
    print(text)
    if args.out is not None:
        bench.write_section(args.out, SECTION, text)
    return results
