# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench startup``: process start to the first ``World.step``, cold and cached.

A fresh Python process loads the packaged default scene and steps it once, for each
integrator asked. *Cold* runs with an empty numba cache directory (``NUMBA_CACHE_DIR``), so
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

SECTION = 'rigid_sim_bench startup'
REPEATS = 3
# The child: load the default scene, warm up, step once; prints the warm-up seconds.
CHILD = '''
from rigid_sim.core.scene import build_world, load_scene
from rigid_sim.core.warm_up import warm_up
from rigid_sim.resources import find_scene
world = build_world(load_scene(find_scene('default.yaml')), {integrator!r})
seconds = warm_up(world)
assert world.step(0.01)
print(seconds)
'''


def start_once(integrator, cache_dir):
    """Wall seconds of one child process, and the compile seconds it reported."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, '-c', CHILD.format(integrator=integrator)],
                          env=environment, capture_output=True, text=True, check=True)
    return time.perf_counter() - start, float(done.stdout.split()[-1])


def measure(integrators, repeats):
    """``{integrator: (cold, cached)}``, each (wall s, compile s), medians of ``repeats``."""
    results = {}
    for integrator in integrators:
        cold, cached = [], []
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as cache_dir:
                cold.append(start_once(integrator, Path(cache_dir)))
                cached.append(start_once(integrator, Path(cache_dir)))
        results[integrator] = tuple(sorted(runs)[len(runs) // 2] for runs in (cold, cached))
    return results


def report(results):
    """Format the Markdown section: setup and one row per integrator."""
    rows = [[name, f'{cold[0]:.2f}', f'{cold[1]:.2f}', f'{cached[0]:.2f}', f'{cached[1]:.2f}']
            for name, (cold, cached) in results.items()]
    machine = [line for line in bench.machine_description() if 'CPU time' not in line]
    return '\n'.join(['### Setup', *machine,
                      f'- Command: `{bench.command_line()}`',
                      '- Wall time of a fresh process: import, default scene, warm-up, one step',
                      '', '### Start-up [s] (median of the repeats)',
                      bench.markdown_table(['integrator', 'cold: process', 'cold: compile',
                                            'cached: process', 'cached: load'], rows)])


def add_arguments(parser):
    """Options of ``rigid_sim_bench startup``."""
    parser.add_argument('--integrators', nargs='+', default=[DEFAULT_INTEGRATOR, 'rk4'],
                        help='integrators to start with')
    parser.add_argument('--repeats', type=int, default=REPEATS, help='starts per setting')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Run the benchmark, print the Markdown report and write ``--out``."""
    results = measure(args.integrators, args.repeats)
    text = report(results)
    print(text)
    if args.out is not None:
        bench.write_section(args.out, SECTION, text)
    return results
