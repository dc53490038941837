# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench accuracy``: what each integrator's accuracy costs in CPU time.

Every registered integrator runs every case of :mod:`rigid_sim.bench.cases` at each fixed
step or, if adaptive, each tolerance (the whole interval asked of it in one call); the final
state is scored against the case's exact oracle. A setting whose estimated cost exceeds the
budget, or finer than one whose error already sits at round-off, is skipped and listed.
A method's own internal steps (``dopri5``'s) show in its count of wrench (RHS) evaluations.
"""
import dataclasses
import functools
import sys
import time
from pathlib import Path

import numpy as np

from rigid_sim import bench
from rigid_sim.bench.cases import CASES, CASES_BY_KEY, score
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.state import ANGULAR_MOMENTUM, ORIENTATION, POSITION
from rigid_sim.core.warm_up import warm_up

TOLERANCES = tuple(10.0 ** -k for k in range(3, 12))   # adaptive error targets swept
ERROR_LEVELS = tuple(10.0 ** -k for k in range(3, 10))  # rad, for the cost-per-accuracy table
ROUND_OFF = 1e-12   # rad or m: finer settings would measure round-off, not the method
REPEATS = 5         # timed runs per setting; the median is reported
BUDGET = 8.0        # CPU s per setting, all repeats; a costlier setting is skipped
QUICK = dict(duration=1.0, steps=(1e-1, 5e-2), tolerances=(1e-3, 1e-5), repeats=1)
BUDGET_CHECK_STEPS = 100  # steps between checks that a run still fits the budget
UNCAPPED = 10 ** 9  # internal steps one adaptive call may take here (see measure_rigid)
SECTION = 'rigid_sim_bench accuracy'
PLOT_NAME = 'accuracy_work_precision.png'


def measure_rigid(case, setting, repeats, budget, method):
    """Median CPU time of ``repeats`` runs of a registered integrator on ``case``, scored.

    Raises OverBudget when the repeats would take more than ``budget`` CPU seconds.
    """
    adaptive = REGISTRY[method].adaptive
    steps, dt = ((1, case.duration) if adaptive
                 else (int(round(case.duration / setting)), setting))
    worlds = []

    def prepare():
        # Nothing here reads the error estimate: the methods that can skip it do, as the
        # Yoshida compositions' costs two more steps.
        world = case.build(method, tolerance=setting if adaptive else 1e-6, estimates=False)
        if adaptive:
            # The cap bounds the node's work per tick; here there is no tick, and the whole
            # interval is one call whose accuracy against work is measured: a capped call
            # would give up and score as diverged. The node keeps its cap.
            world.integrator.cap = UNCAPPED
        # Untimed: a method's first run in this process would otherwise time numba's
        # compile or cache load (seconds), and its first setting be skipped as over budget.
        warm_up(world)
        worlds.append((world, case.energy(world),
                       np.linalg.norm(world.y[0, ANGULAR_MOMENTUM])))

        def run():
            start = time.process_time()
            with np.errstate(all='ignore'):   # a diverging run is scored, not raised
                for done in range(1, steps + 1):
                    world.step(dt)
                    if done % BUDGET_CHECK_STEPS == 0:
                        elapsed = time.process_time() - start
                        # Stop a hopeless run early rather than spend the budget learning so.
                        if elapsed * repeats > budget:
                            raise bench.OverBudget(elapsed * steps / done)
        return run
    cpu_time, _ = bench.median_cpu_time(prepare, repeats, budget)
    world, energy0, momentum0 = worlds[-1]
    y = world.y[0]
    with np.errstate(all='ignore'):   # a diverged run's energy overflows; it is scored so
        final = (y[ORIENTATION], world.snapshot().angular_velocity[0], case.energy(world),
                 y[ANGULAR_MOMENTUM], y[POSITION])
    if world.diagnostics.failed_steps:   # the World kept an earlier state: nothing to score
        final = tuple(np.full(np.shape(part), np.nan) for part in final)
    return score(case, method, setting, adaptive, final, (energy0, momentum0),
                 float(world.integrator.evaluations), cpu_time)


def skip_reason(case, previous):
    """Why the next (finer) setting is not run, judged from the previous one, or None.

    Cost is not: a method may take a coarse step in internal steps, so a finer setting can cost
    less; the first timed run of each setting decides (``bench.OverBudget``).
    """
    if previous is None:
        return None
    error = previous.error(case.primary)
    # Energy too, so a diverged run that lands near the answer by chance stops nothing.
    if error < ROUND_OFF and previous.energy_drift < ROUND_OFF:
        return f'error already {error:.1e} (round-off) at a coarser setting'
    return None


def sweep(jobs, options):
    """Measure every job at every setting. Returns results and (job, setting, why) skipped.

    ``jobs``: (case, label, measure, adaptive), ``measure(case, setting, repeats, budget)``;
    ``options``: ``repeats``, ``budget`` (s), ``tolerances``, ``progress`` (bool).
    """
    grids = [options['tolerances'] if adaptive else case.steps for case, _, _, adaptive in jobs]
    try:   # the 'bench' extra; imported here so that rigid_sim_bench --help needs none
        from tqdm import tqdm
    except ImportError:
        raise bench.MissingPackage("a progress bar needs tqdm: pip install -e '.[bench]'")
    bar = tqdm(total=sum(map(len, grids)), disable=not options['progress'], file=sys.stderr,
               unit='setting')
    results, skipped = [], []
    for (case, label, measure, adaptive), grid in zip(jobs, grids):
        previous = None
        for setting in grid:
            bar.set_description(f'{case.key} {label} {setting:g}')
            bar.update()
            reason = skip_reason(case, previous)
            if reason is None:
                try:
                    previous = measure(case, setting, options['repeats'], options['budget'])
                    results.append(previous)
                    continue
                except bench.OverBudget as over:
                    reason = (f'one run takes ~{over.args[0]:.1f} s: {options["repeats"]} '
                              f'exceed the budget {options["budget"]:g} s')
            skipped.append((f'{case.key} / {label}', setting, reason))
    bar.close()
    return results, skipped


def jobs(cases, methods, mujoco_integrators):
    """(case, label, measure, adaptive) for every registered method and MuJoCo integrator."""
    listed = [(case, m, functools.partial(measure_rigid, method=m), REGISTRY[m].adaptive)
              for case in cases for m in methods]
    if mujoco_integrators:
        from rigid_sim.bench import mujoco_baseline   # optional: only under --compare mujoco
        listed += [(case, 'mujoco ' + m, functools.partial(mujoco_baseline.measure,
                                                           integrator=m), False)
                   for case in cases if case.mujoco for m in mujoco_integrators]
    return listed


def case_table(results, case):
    """Markdown table of every result of ``case``."""
    header = ('method', 'dt (s) / tol', 'orientation err (rad)', 'omega err (rel)',
              'position err (m)', 'energy drift (rel)', '|L| drift (rel)', 'RHS evals',
              'CPU (ms)')
    rows = [(r.method, ('tol ' if r.adaptive else '') + f'{r.setting:g}',
             bench.scientific(r.orientation_error), bench.scientific(r.omega_error),
             bench.scientific(r.position_error), bench.scientific(r.energy_drift),
             bench.scientific(r.momentum_drift),
             '-' if np.isnan(r.evaluations) else f'{r.evaluations:.0f}',
             f'{1e3 * r.cpu_time:.3g}')
            for r in results if r.case == case.key]
    return bench.markdown_table(header, rows)


def cheapest(results, case_key, level, methods, kind='orientation'):
    """Return the least CPU time among ``methods`` reaching a ``kind`` error <= ``level``."""
    hits = [r for r in results if r.case == case_key and r.method in methods
            and r.error(kind) <= level]
    return min(hits, key=lambda r: r.cpu_time, default=None)


def cost_per_accuracy(results, case_key='tumbling', kind='orientation'):
    """Markdown: per ``kind`` error level, the cheapest rigid_sim run against MuJoCo RK4's."""
    ours = set(REGISTRY)
    rows = []
    for level in ERROR_LEVELS:
        best = cheapest(results, case_key, level, ours, kind)
        theirs = cheapest(results, case_key, level, {'mujoco RK4'}, kind)
        describe = (lambda r: '-' if r is None else
                    f'{r.method} {"tol " if r.adaptive else "dt "}{r.setting:g}: '
                    f'{1e3 * r.cpu_time:.3g} ms')
        ratio = f'{best.cpu_time / theirs.cpu_time:.2g}' if best and theirs else '-'
        rows.append((f'{level:.0e}', describe(best), describe(theirs), ratio))
    return bench.markdown_table(
        (f'{kind} error <=', 'cheapest rigid_sim', 'MuJoCo RK4', 'CPU ratio (ours/MuJoCo)'),
        rows)


def energy_at_step(results, case_key='fast_spin', dt=1e-2):
    """Markdown: energy drift and orientation error of every fixed-step run at ``dt``."""
    rows = [(r.method, bench.scientific(r.energy_drift), bench.scientific(r.orientation_error))
            for r in results if r.case == case_key and not r.adaptive
            and np.isclose(r.setting, dt)]
    return bench.markdown_table(('method', 'energy drift (rel)', 'orientation err (rad)'), rows)


def plot(results, cases, path):
    """Log-log work-precision plot: error against CPU time, a panel per case.

    Diverged runs are left out; MuJoCo's integrators are the black dashed lines.
    """
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    columns = 2
    rows = -(-len(cases) // columns)
    figure, axes = pyplot.subplots(rows, columns, figsize=(12, 5 * rows), squeeze=False)
    for ax, case in zip(axes.flat, cases):
        mine = [r for r in results if r.case == case.key and np.isfinite(r.error(case.primary))]
        for index, method in enumerate(dict.fromkeys(r.method for r in mine)):
            runs = sorted((r for r in mine if r.method == method), key=lambda r: r.cpu_time)
            # An exact zero cannot sit on a log axis: draw it at the bottom of the range.
            error = np.maximum([r.error(case.primary) for r in runs], 1e-16)
            style = (dict(color='black', linestyle='--', marker='sDo'[index % 3])
                     if method.startswith('mujoco') else dict(color=f'C{index}', marker='o'))
            ax.loglog([r.cpu_time for r in runs], error, markersize=3, label=method, **style)
        ax.set_title(case.title, fontsize=9)
        ax.set_xlabel('CPU time (s)')
        ax.set_ylabel(f'final {case.primary} error ({"rad" if case.primary[0] == "o" else "m"})')
        ax.grid(True, which='both', alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    for ax in axes.flat[len(cases):]:
        ax.set_visible(False)
    figure.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    pyplot.close(figure)


def skipped_notes(skipped):
    """Markdown list: one line per job and setting not run, with the reason."""
    return '\n'.join(f'- {job} / {setting:g}: {reason}' for job, setting, reason in skipped)


def report(results, skipped, cases, plot_path, versions):
    """Return the Markdown section: setup, a table per case, skipped settings, plot, readings."""
    parts = ['## Integrator accuracy against CPU time', f'Command: `{bench.command_line()}`',
             '\n'.join(bench.machine_description(versions)),
             'Errors are at the final time against each case\'s exact oracle. Adaptive methods '
             'are asked for the whole interval in one call; MuJoCo runs it in one '
             '`mj_step(nstep)` call (no Python per step).']
    for case in cases:
        parts += [f'### {case.key}: {case.title}, T = {case.duration:g} s',
                  case_table(results, case)]
    if skipped:
        parts += ['### Settings not run', skipped_notes(skipped)]
    if plot_path is not None:
        parts += ['### Work-precision plot', f'![error against CPU time]({plot_path})']
    keys = [case.key for case in cases]
    for case in cases:
        if case.mujoco and case.key != 'fast_spin':
            parts += [f'### Cheapest run at each {case.primary}-error level, {case.key}',
                      cost_per_accuracy(results, case.key, case.primary)]
    if 'fast_spin' in keys:
        parts += ['### Fast spin at dt = 1e-2: energy', energy_at_step(results)]
    return '\n\n'.join(parts)


def add_arguments(parser):
    """Options of ``rigid_sim_bench accuracy``."""
    parser.add_argument('--cases', nargs='+', choices=list(CASES_BY_KEY),
                        default=[case.key for case in CASES])
    parser.add_argument('--methods', nargs='+', choices=sorted(REGISTRY), default=list(REGISTRY))
    parser.add_argument('--compare', choices=['mujoco'],
                        help="also run MuJoCo's Euler, implicitfast and RK4 (optional package)")
    parser.add_argument('--quick', action='store_true', help='a tiny configuration (seconds)')
    parser.add_argument('--repeats', type=int, default=REPEATS, help='timed runs per setting')
    parser.add_argument('--budget', type=float, default=BUDGET,
                        help='CPU seconds per setting (all repeats); costlier ones are skipped')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')
    parser.add_argument('--plot', type=Path, help=f'plot file (default: {PLOT_NAME} by --out)')
    parser.add_argument('--no-progress', action='store_true', help='no progress bar')


def main(args):
    """Run the sweep, print the Markdown report, write ``--out`` and the plot; the results."""
    versions, integrators = [], ()
    if args.compare == 'mujoco':
        from rigid_sim.bench import mujoco_baseline
        versions.append(f'mujoco {mujoco_baseline.require()}')
        integrators = mujoco_baseline.INTEGRATORS
    cases = [CASES_BY_KEY[key] for key in args.cases]
    options = dict(repeats=args.repeats, budget=args.budget, tolerances=TOLERANCES,
                   progress=not args.no_progress)
    if args.quick:
        cases = [dataclasses.replace(case, duration=QUICK['duration'], steps=QUICK['steps'])
                 for case in cases]
        options.update(repeats=QUICK['repeats'], tolerances=QUICK['tolerances'])
    results, skipped = sweep(jobs(cases, args.methods, integrators), options)
    plot_path = args.plot or (args.out.parent / PLOT_NAME if args.out else None)
    link = None
    if plot_path is not None:
        plot(results, cases, plot_path)
        link = plot_path.name if args.out and plot_path.parent == args.out.parent else plot_path
    text = report(results, skipped, cases, link, versions)
    print(text)
    if args.out:
        bench.write_section(args.out, SECTION, text)
    return results
