# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench startup``: process start to the first ``World.step``, cold and cached.

A fresh Python process loads a scene (by default each packaged one) and steps it once, for
each integrator asked. *Cold* runs with an empty numba cache directory (``NUMBA_CACHE_DIR``), so
every kernel that step uses is compiled; *cached* runs again with the same directory, so
they are loaded from disk. Wall time of the whole process (interpreter start included), and
the compile time :func:`rigid_sim.core.warm_up.warm_up` reports inside it.
"""
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rigid_sim import bench
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
seconds, compiled = warm_up_reporting(world, imus=scene_imus(scene, world.bodies))
assert world.step(0.01)
print(seconds, compiled)
'''


def packaged_scenes():
    """File names of the scenes shipped in ``config/scenes``."""
    return sorted(path.name for path in Path(find_scene(DEFAULT_SCENE)).parent.glob('*.yaml'))


def start_once(scene, integrator, cache_dir):
    """Wall seconds of one child process, the compile seconds and kernel count it reported."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, '-c', CHILD.format(scene=scene,
                                                              integrator=integrator)],
                          env=environment, capture_output=True, text=True, check=True)
    seconds, compiled = done.stdout.split()[-2:]
    return time.perf_counter() - start, float(seconds), int(compiled)


def measure(scenes, integrators, repeats):
    """``{(scene, integrator): (cold, cached)}``, each (wall s, compile s, kernels).

    Medians of ``repeats`` starts, each cold one with an empty cache.
    """
    results = {}
    for scene in scenes:
        for integrator in integrators:
            cold, cached = [], []
            for _ in range(repeats):
                with tempfile.TemporaryDirectory() as cache_dir:
                    cold.append(start_once(scene, integrator, Path(cache_dir)))
                    cached.append(start_once(scene, integrator, Path(cache_dir)))
            results[scene, integrator] = tuple(sorted(runs)[len(runs) // 2]
                                               for runs in (cold, cached))
    return results


def report(results):
    """Format the Markdown section: setup and one row per scene and integrator."""
    rows = [[scene, name, str(cold[2]), f'{cold[0]:.2f}', f'{cold[1]:.2f}', f'{cached[0]:.2f}',
             f'{cached[1]:.2f}'] for (scene, name), (cold, cached) in results.items()]
    machine = [line for line in bench.machine_description() if 'CPU time' not in line]
    return '\n'.join(['### Setup', *machine,
                      f'- Command: `{bench.command_line()}`',
                      '- Wall time of a fresh process: import, scene, warm-up, one step; '
                      'kernels: the specialisations the cold start compiled',
                      '', '### Start-up [s] (median of the repeats)',
                      bench.markdown_table(['scene', 'integrator', 'kernels', 'cold: process',
                                            'cold: compile', 'cached: process',
                                            'cached: load'], rows)])


def add_arguments(parser):
    """Options of ``rigid_sim_bench startup``."""
    parser.add_argument('--scenes', nargs='+', help='scene files (default: every packaged one)')
    parser.add_argument('--integrators', nargs='+', default=[DEFAULT_INTEGRATOR],
                        help='integrators to start with')
    parser.add_argument('--repeats', type=int, default=REPEATS, help='starts per setting')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Run the benchmark, print the Markdown report and write ``--out``."""
    results = measure(args.scenes or packaged_scenes(), args.integrators, args.repeats)
    text = report(results)
    print(text)
    if args.out is not None:
        bench.write_section(args.out, SECTION, text)
    return results
