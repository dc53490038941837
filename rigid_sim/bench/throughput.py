# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench throughput``: CPU time per body-step against the number of bodies.

N free bodies (1 kg, diag(0.1, 0.2, 0.3) kg m^2, each with its own tilt and spin) under
gravity and a held body-frame wrench, dt = 2e-3, every registered integrator; MuJoCo's Euler
and RK4 on the same N free bodies in the same run when ``mujoco`` is installed (one
``mj_step(model, data, nstep)`` call: its compiled loop, its best case). Also the cost of each
effect's compiled wrench at one N, and that a world without effects runs no effect code.
Kernels are compiled (or loaded from numba's cache) before any timing.
"""
import cProfile
import functools
import pstats
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim import bench
from rigid_sim.bench import body_threads
from rigid_sim.core.effects.base import accumulate
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import Springs, SpringSpec
from rigid_sim.core.integrators import DEFAULT_INTEGRATOR, REGISTRY
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World

DT = 2e-3                      # s, the step of every run
MOMENTS = (0.1, 0.2, 0.3)      # kg m^2
GRAVITY = (0.0, 0.0, -9.81)    # m/s^2
FORCE, TORQUE = (1.0, 0.5, 0.0), (0.0, 0.02, 0.01)   # held body-frame wrench, N and N m
SIZES = (1, 10, 100, 1000, 10000)
WORK = 50000                   # body-steps per timed run: fewer steps at large N bound the run
RUN_SECONDS = 0.25             # CPU s per timed run at most (slow methods take fewer steps)
CALIBRATION_STEPS = 3          # untimed steps that estimate the cost of one
REPEATS = 5
EFFECT_SIZE = 1000
QUICK = dict(sizes=(1, 10), work=20, repeats=5, effect_size=10,
             thread_sizes=body_threads.QUICK_SIZES)
SECTION = 'rigid_sim_bench throughput'
# Rows that add the World's step-size guard: row name -> integrator (exact_split: the default).
GUARDED = {f'{name}, World auto_substep on': name for name in ('rk4', 'exact_split')}
# Rows of the methods that skip their estimate when nothing reads it (World(estimates=False)).
UNESTIMATED = {f'{name}, no estimate': name for name, cls in sorted(REGISTRY.items())
               if cls.estimate_optional}
# MuJoCo's default arena is too small for 1e4 bodies; ~20 kB a free body is ample.
MUJOCO_MODEL = """<mujoco><size memory="{memory}M"/>
<option timestep="{dt}" gravity="{g}" integrator="{integrator}">
<flag contact="disable"/></option><worldbody>{bodies}</worldbody></mujoco>"""
MUJOCO_BODY = ('<body pos="{x} 0 0"><freejoint/><inertial pos="0 0 0" mass="1" '
               'diaginertia="{i}"/></body>')


@functools.lru_cache(maxsize=None)
def bodies_and_state(n):
    """N identical-mass bodies with distinct orientations and spins: RigidBodies, y (N, 13).

    Cached, as is each effect set built for them: no run changes either (a World copies
    ``y``; effects keep no state while stepping).
    """
    bodies = RigidBodies(names=tuple(f'body{i}' for i in range(n)), mass=np.ones(n),
                         inertia_body=np.repeat(np.diag(MOMENTS)[None], n, axis=0),
                         com_in_body=np.zeros((n, 3)))
    generator = np.random.default_rng(n)
    y = initial_state(bodies, generator.normal(size=(n, 3)),
                      Rotation.random(n, random_state=n).as_quat(),
                      generator.normal(size=(n, 3)), generator.normal(scale=2.0, size=(n, 3)))
    return bodies, y


@functools.lru_cache(maxsize=None)
def held_wrenches(n):
    """Build the world's inputs for N bodies: the same body-frame wrench held on each."""
    wrenches = AppliedWrenches(bodies_and_state(n)[0])
    for i in range(n):
        wrenches.hold(i, 'bench', 'body', FORCE, TORQUE)
    return wrenches


@functools.lru_cache(maxsize=None)
def effects_of(n, kinds):
    """Return the effects named in ``kinds`` (gravity, damping, springs) for N bodies."""
    bodies, built = bodies_and_state(n)[0], []
    kinds = (kinds,) if isinstance(kinds, str) else kinds
    for kind in kinds:
        if kind == 'gravity':
            built.append(Gravity(bodies, GRAVITY))
        elif kind == 'damping':
            built.append(Damping(bodies, linear=0.05, angular=0.01))
        elif kind == 'springs':   # each body to a world anchor, and to its neighbour
            specs = [SpringSpec(i, np.array([0.1, 0, 0]), 10.0, 0.1, anchor=np.zeros(3))
                     for i in range(n)]
            specs += [SpringSpec(i, np.zeros(3), 5.0, 0.1, 0.2, other=i + 1,
                                 other_point=np.zeros(3)) for i in range(n - 1)]
            built.append(Springs(bodies, specs))
    return tuple(built)


def rigid_sim_time(n, integrator, work, repeats, auto_substep=False, clock=time.process_time,
                   estimates=True):
    """Median CPU seconds per ``World.step`` of N bodies with ``integrator``.

    ``auto_substep`` off times the integrator itself (its error estimate included, unless
    ``estimates`` is False); on adds the World's step-size guard and error control.
    ``clock``: ``time.perf_counter`` for wall seconds.
    """
    def prepare():
        bodies, y = bodies_and_state(n)
        world = World(bodies, y, effects_of(n, 'gravity'), integrator,
                      auto_substep=auto_substep, inputs=held_wrenches(n),
                      error_control=auto_substep, estimates=estimates)
        return lambda: [world.step(DT) for _ in range(steps)]

    steps = 1
    prepare()()   # compiles the kernels (or loads them from numba's cache): not timed
    steps = CALIBRATION_STEPS
    calibration, _ = bench.median_cpu_time(prepare, 1, clock=clock)
    per_step = max(calibration / steps, 1e-9)
    steps = int(max(CALIBRATION_STEPS, min(work // n, RUN_SECONDS / per_step)))
    return bench.median_cpu_time(prepare, repeats, clock=clock)[0] / steps


def mujoco_time(n, integrator, work, repeats, clock=time.process_time):
    """Median ``clock`` seconds per step of N free MuJoCo bodies (gravity, xfrc_applied)."""
    import mujoco
    steps = max(3, work // n)
    inertia = ' '.join(map(str, MOMENTS))
    bodies = ''.join(MUJOCO_BODY.format(x=2 * i, i=inertia) for i in range(n))
    xml = MUJOCO_MODEL.format(memory=10 + n // 50, dt=DT, g=' '.join(map(str, GRAVITY)),
                              integrator=integrator, bodies=bodies)
    model = mujoco.MjModel.from_xml_string(xml)

    def prepare():
        data = mujoco.MjData(model)
        data.qvel[:] = np.random.default_rng(n).normal(size=model.nv)
        # Body 0 is the world; xfrc_applied is world-axes force then torque at the com.
        data.xfrc_applied[1:] = np.concatenate((FORCE, TORQUE))
        return lambda: mujoco.mj_step(model, data, nstep=steps)
    return bench.median_cpu_time(prepare, repeats, clock=clock)[0] / steps


def effect_costs(n, repeats):
    """CPU seconds of one compiled wrench sum of each effect alone at N bodies, per kind.

    Each call from Python includes numba's dispatch, which a step pays once per
    stage for all its effects together, not per effect.
    """
    bodies, y = bodies_and_state(n)
    costs = {}
    kinds = {kind: (effects_of(n, kind)[0].parameters,)
             for kind in ('gravity', 'damping', 'springs')}
    kinds['wrench'] = (held_wrenches(n).parameters,)
    for kind, parameters in kinds.items():
        calls = max(10, 20000 // n)

        def prepare():
            force, torque = np.zeros((n, 3)), np.zeros((n, 3))
            accumulate(parameters, y, 0.0, bodies.model, force, torque)   # compiled here

            def run():
                for _ in range(calls):
                    accumulate(parameters, y, 0.0, bodies.model, force, torque)
            return run
        costs[kind] = bench.median_cpu_time(prepare, repeats)[0] / calls
    return costs


def effect_calls_without_effects(n, integrator='rk4', steps=5):
    """Count the calls into ``rigid_sim/core/effects`` while a world with no effects steps.

    The first step, which compiles the kernel (numba's typing calls into the effects'
    overloads) or loads it from the cache, is not counted: it is not a step's cost.
    """
    bodies, y = bodies_and_state(n)
    world = World(bodies, y, (), integrator)
    world.step(DT)
    profile = cProfile.Profile()
    profile.runcall(lambda: [world.step(DT) for _ in range(steps)])
    stats = pstats.Stats(profile).stats
    return sum(calls[1] for (path, _, _), calls in stats.items()
               if str(Path('core', 'effects')) in path)


def sweep(sizes, work, repeats, with_mujoco):
    """Seconds per step, ``{method: {N: s}}``, for every integrator and MuJoCo's two."""
    results = {name: {n: rigid_sim_time(n, name, work, repeats) for n in sizes}
               for name in sorted(REGISTRY)}
    for row, name in GUARDED.items():
        results[row] = {n: rigid_sim_time(n, name, work, repeats, True) for n in sizes}
    for row, name in UNESTIMATED.items():
        results[row] = {n: rigid_sim_time(n, name, work, repeats, estimates=False)
                        for n in sizes}
    if with_mujoco:
        for integrator in ('Euler', 'RK4'):
            results['mujoco ' + integrator] = {
                n: mujoco_time(n, integrator, work, repeats) for n in sizes}
    return results


def throughput_table(results, sizes):
    """Markdown: microseconds per body-step, a row per method, a column per N."""
    header = ['method'] + [f'N = {n:g}' for n in sizes]
    rows = [[name] + [f'{1e6 * results[name][n] / n:.3g}' for n in sizes] for name in results]
    return bench.markdown_table(header, rows)


def ratio_table(results, sizes):
    """Markdown: MuJoCo RK4's time per step over each order-4 method's, per N."""
    if 'mujoco RK4' not in results:
        return 'MuJoCo is not installed: no ratios.'
    reference = results['mujoco RK4']
    names = [name for name, cls in sorted(REGISTRY.items()) if cls.order >= 4]
    names += [DEFAULT_INTEGRATOR, 'semi_implicit_euler'] + list(GUARDED) + list(UNESTIMATED)
    rows = [[name] + [f'{reference[n] / results[name][n]:.3g}' for n in sizes]
            for name in names if name in results]
    return bench.markdown_table(['MuJoCo RK4 / method'] + [f'N = {n:g}' for n in sizes], rows)


def plot(results, sizes, path):
    """Log-log plot of microseconds per body-step against N."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    figure, axes = pyplot.subplots(figsize=(8, 6))
    for name, times in results.items():
        style = '--' if name.startswith('mujoco') else '-'
        axes.loglog(sizes, [1e6 * times[n] / n for n in sizes], style, marker='o', label=name)
    axes.set_xlabel('bodies N')
    axes.set_ylabel('CPU time per body-step [us]')
    axes.set_title(f'Throughput: gravity + held body wrench, dt = {DT:g} s')
    axes.grid(True, which='both', alpha=0.3)
    axes.legend(fontsize=8)
    figure.savefig(path, dpi=100, bbox_inches='tight')
    pyplot.close(figure)


def report(results, sizes, costs, effect_size, idle_calls, versions, plot_link, walls):
    """Return the Markdown section: setup, body-step table, ratios, effect costs, idle proof.

    ``walls``: the wall-clock table of one thread against threads (:mod:`.body_threads`).
    """
    effect_rows = [[kind, f'{1e6 * cost:.3g}', f'{1e9 * cost / effect_size:.3g}']
                   for kind, cost in costs.items()]
    parts = ['### Setup', *bench.machine_description(versions),
             f'- Command: `{bench.command_line()}`',
             '', '### CPU time per body-step [us] (median of the repeats)',
             throughput_table(results, sizes),
             '', '### MuJoCo RK4 time per step over ours (> 1: ours is faster)',
             ratio_table(results, sizes),
             '', f'### One compiled wrench sum of each effect alone at N = {effect_size}',
             bench.markdown_table(['effect', 'us per call', 'ns per body'], effect_rows),
             '', '### An unlisted effect costs nothing',
             f'A world with no effects, stepped 5 times with rk4, made {idle_calls} calls '
             'into `rigid_sim/core/effects` (cProfile).', '', walls]
    if plot_link is not None:
        parts += ['', f'![us per body-step against N]({plot_link})']
    return '\n'.join(parts)


def add_arguments(parser):
    """Options of ``rigid_sim_bench throughput``."""
    parser.add_argument('--quick', action='store_true',
                        help='tiny configuration (N = 1, 10; few steps) for tests')
    parser.add_argument('--sizes', type=int, nargs='+', help=f'body counts (default {SIZES})')
    parser.add_argument('--thread-sizes', type=int, nargs='+',
                        help=f'body counts of the wall-clock table (default {body_threads.SIZES})')
    parser.add_argument('--repeats', type=int, default=REPEATS, help='timed runs per setting')
    parser.add_argument('--no-mujoco', action='store_true', help='skip the MuJoCo columns')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')
    parser.add_argument('--plot', type=Path, help='plot file (default performance.png by --out)')


def main(args):
    """Run the benchmark, print the Markdown report, write ``--out`` and the plot."""
    quick = QUICK if args.quick else dict(sizes=SIZES, work=WORK, repeats=args.repeats,
                                          effect_size=EFFECT_SIZE,
                                          thread_sizes=body_threads.SIZES)
    sizes = tuple(args.sizes or quick['sizes'])
    versions = []
    try:
        import mujoco
        versions.append(f'mujoco {mujoco.__version__}')
    except ImportError:   # optional: the table then has no MuJoCo rows
        mujoco = None
    with body_threads.threads_from(body_threads.NEVER):   # CPU time: one thread's
        results = sweep(sizes, quick['work'], quick['repeats'],
                        mujoco is not None and not args.no_mujoco)
    thread_sizes = tuple(args.thread_sizes or quick['thread_sizes'])
    walls = body_threads.wall_sweep(thread_sizes, quick['work'], quick['repeats'],
                                    mujoco is not None and not args.no_mujoco)
    costs = effect_costs(quick['effect_size'], quick['repeats'])
    idle_calls = effect_calls_without_effects(quick['effect_size'])
    plot_path = args.plot or (args.out.parent / 'performance.png' if args.out else None)
    link = None
    if plot_path is not None:
        plot_path.parent.mkdir(parents=True, exist_ok=True)
        plot(results, sizes, plot_path)
        link = plot_path.name if args.out and plot_path.parent == args.out.parent else plot_path
    text = report(results, sizes, costs, quick['effect_size'], idle_calls, versions, link,
                  body_threads.wall_report(walls, thread_sizes))
    print(text)
    if args.out is not None:
        bench.write_section(args.out, SECTION, text)
    return results
