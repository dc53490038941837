# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench estimates``: every integrator's local error estimate against the truth.

Each case (the hard cases of :mod:`rigid_sim.bench.stability`, the accuracy cases of
:mod:`rigid_sim.bench.cases` at one step, the cases of :mod:`rigid_sim.bench.estimate_cases`)
runs through each integrator. At ticks spread over
the run, the step taken from the world's own state is compared with the reference from that
same state over the same ``dt``: DOP853 (:func:`rigid_sim.bench.oracles.reference_motion`,
rtol 1e-13, atol 1e-14 of each component's scale) whose wrench is the world's own effect sum
(``World.wrench``) at the oracle's state, so the reference solves the integrators' equations
with an integrator of its own. Both errors are in the scaled units of
:mod:`rigid_sim.core.error_estimate`.

1. Bare methods (no substeps): the ratio estimate / true error per sampled tick, its median
   and extremes, flagged when beyond :data:`FACTOR` either way.
2. Error control at each of :data:`TOLERANCES`: the largest true error of a step over the
   tolerance, and the mean substeps.
"""
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigid_sim import bench
from rigid_sim.bench import cases as accuracy_cases
from rigid_sim.bench import estimate_cases, oracles, stability
from rigid_sim.core.error_estimate import true_errors
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.state import Snapshot
from rigid_sim.core.world import World

SAMPLES = 20          # ticks sampled per run, spread over it
FLOOR = 1e-13         # scaled error below which estimate and truth are round-off alike
# A body far from the origin has its position's round-off, eps |x|, as error floor: this many
# units in the last place, in units of its size, raise FLOOR for it.
ROUND_OFF_ULPS = 8
FACTOR = 10.0         # an estimate within this factor of the truth either way is good
TOLERANCES = (1e-6, 1e-4)
ACCURACY_DT = 1e-2    # s, the step the accuracy cases run at
ESTIMATE_STEPS = 100  # steps of each case of rigid_sim.bench.estimate_cases
CONTROLLED_STEPS = 200  # an error-controlled run stops after this many steps
ORACLE_RTOL = 1e-13
ORACLE_ATOL = 1e-14   # times each component's scale
# Wrench evaluations the oracle may spend on one step (~2 s): a diverged state spinning at
# millions of radians per step is not worth following.
ORACLE_EVALUATIONS = 100_000
UNDER, OVER, GOOD, ROUND_OFF = 'SILENT UNDERESTIMATE', 'overestimate', 'within 10x', 'round-off'
QUICK = dict(cases=('tumbling', 'acc_spring'), steps=12, samples=3)
SECTION = 'rigid_sim_bench estimates'
PLOT_NAME = 'error_estimates.png'


@dataclass(frozen=True)
class Probe:
    """A case as this benchmark runs it: ``build(integrator)`` returns its bare World."""

    key: str
    title: str
    dt: float         # s
    duration: float   # s
    build: object


def probes():
    """Every case: the hard cases at their test duration, then the accuracy cases."""
    hard = [Probe(c.key, c.title, c.dt, c.duration,
                  lambda name, c=c: c.build(name, False)) for c in stability.CASES]
    return hard + [Probe('acc_' + c.key, c.title, ACCURACY_DT, c.duration,
                         lambda name, c=c: c.build(name)) for c in accuracy_cases.CASES] + [
        Probe('est_' + c.key, c.title, c.dt, ESTIMATE_STEPS * c.dt,
              lambda name, c=c: c.world(name)) for c in estimate_cases.CASES.values()]


PROBES = {probe.key: probe for probe in probes()}


def controlled(world, tolerance):
    """Return the same world, not yet stepped, under error control at ``tolerance``."""
    return World(world.bodies, world.initial, world.effects, world.integrator.name, tolerance,
                 auto_substep=True, inputs=world.inputs, error_control=True)


def _pack(bodies, x, v, q, omega_body):
    """Packed (1, 13) state of body 0 from the oracle's ``[x, v, q, omega_b]``."""
    spin = oracles.world_from_body(q) @ bodies.inertia_body[0] @ omega_body
    return np.concatenate((x, q, bodies.mass[0] * v, spin))[None]


def reference_step(world, y, start, dt):
    """Return the state (1, 13) a step of ``dt`` from ``y`` at ``start`` (s) reaches, by DOP853.

    The wrench is the world's now (call it with the inputs the step held).
    """
    bodies = world.bodies
    if bodies.count != 1:
        raise ValueError(f'the oracle moves one body; the case has {bodies.count}')
    mass, inertia = bodies.mass[0], bodies.inertia_body[0]
    q = y[0, 3:7]
    omega_body = np.linalg.solve(inertia, oracles.world_from_body(q).T @ y[0, 10:])

    evaluations = iter(range(ORACLE_EVALUATIONS))

    def wrench(elapsed, x, v, q, omega_body):
        if next(evaluations, None) is None:
            raise bench.OverBudget(ORACLE_EVALUATIONS)
        force, torque = world.wrench(Snapshot(bodies, _pack(bodies, x, v, q, omega_body),
                                              start + elapsed))
        return force[0], oracles.world_from_body(q).T @ torque[0]
    length = bodies.model.gyration[0]
    scale = np.repeat([length, length / dt, 1.0, 1.0 / dt], [3, 3, 4, 3])
    x, v, q, omega = oracles.reference_motion(
        mass, inertia, (y[0, :3], y[0, 7:10] / mass, q, omega_body), [dt], wrench,
        ORACLE_RTOL, ORACLE_ATOL * scale)
    return _pack(bodies, x[-1], v[-1], q[-1], omega[-1])


def estimate_of(world):
    """Return the estimate (N,) of the step the world just took (a hook for the tests)."""
    return world.integrator.error.copy()


@dataclass
class Run:
    """Sampled steps of one run: estimates and true errors (K, N), what the run cost."""

    estimates: np.ndarray
    true: np.ndarray
    floors: np.ndarray  # (K, N) round-off level of each sampled step, scaled
    substeps: float     # mean substeps per step
    steps: int          # steps taken
    given_up: int       # steps the world gave up (the run stops at the first)
    unreferenced: int   # sampled steps the oracle could not follow (a diverged state)
    capped: int         # steps that needed more than safeguards.MAX_SUBSTEPS
    over: int           # steps kept with an estimate above the world's tolerance
    cpu_time: float     # s


def sampled_run(world, dt, steps, samples):
    """Step ``world`` ``steps`` times by ``dt``; at ``samples`` ticks compare with the oracle."""
    ticks = set(np.linspace(0, steps - 1, min(samples, steps)).round().astype(int).tolist())
    estimates, true, floors = [], [], []
    substeps = done = capped = unreferenced = over = 0
    start = time.process_time()
    with np.errstate(all='ignore'):   # a diverging bare method is measured, not raised
        for tick in range(steps):
            before, now = world.y.copy(), world.time
            if not world.step(dt):
                break
            done += 1
            substeps += world.diagnostics.substeps
            capped += bool(getattr(world.diagnostics.why, 'capped', False))
            over += world.diagnostics.error_estimate > world.control.tolerance
            if tick in ticks and np.isfinite(world.y).all():
                try:
                    reference = reference_step(world, before, now, dt)
                except bench.OverBudget:
                    unreferenced += 1
                    continue
                estimates.append(estimate_of(world))
                true.append(true_errors(world.bodies, reference, world.y, dt))
                floors.append(round_off(world.bodies, reference))
    shape = (-1, world.bodies.count)
    return Run(np.reshape(estimates, shape), np.reshape(true, shape), np.reshape(floors, shape),
               substeps / max(done, 1), done, world.diagnostics.failed_steps, unreferenced,
               capped, over, time.process_time() - start)


def round_off(bodies, y):
    """(N,) scaled error that round-off alone makes of the state ``y`` (N, 13)."""
    position = np.max(np.abs(y[:, :3]), axis=1) / bodies.model.gyration
    return np.maximum(FLOOR, ROUND_OFF_ULPS * np.finfo(float).eps * position)


def ratio_grid(run):
    """Estimate / true error (K, N), both raised to the round-off floor; NaN where both under."""
    ratio = np.maximum(run.estimates, run.floors) / np.maximum(run.true, run.floors)
    ratio[np.maximum(run.estimates, run.true) < run.floors] = np.nan
    return ratio


def ratios(run):
    """Estimate / true error of every sampled (tick, body) not at round-off in both."""
    ratio = ratio_grid(run)
    return ratio[~np.isnan(ratio)]


def flag(values):
    """Judge a run's ratios: a silent underestimate is beyond FACTOR below the truth."""
    if len(values) == 0:
        return ROUND_OFF
    if values.min() < 1.0 / FACTOR or not np.isfinite(values).all():
        return UNDER
    return OVER if values.max() > FACTOR else GOOD


def ratio_cell(run):
    """Markdown cell: median [min, max] of the run's ratios, the flag unless good, gaps."""
    values = ratios(run)
    verdict = flag(values)
    cell = ROUND_OFF
    if verdict != ROUND_OFF:
        cell = f'{np.median(values):.2g} [{values.min():.2g}, {values.max():.2g}]'
        cell = {UNDER: f'**{cell} UNDER**', OVER: f'{cell} over', GOOD: cell}[verdict]
    return cell + missing(run)


def missing(run):
    """Text for a run's steps not compared: the world gave up, the oracle could not follow."""
    text = f', gave up at step {run.steps + 1}' if run.given_up else ''
    return text + (f', {run.unreferenced} diverged' if run.unreferenced else '')


def held(run, tolerance):
    """Return true error / tolerance of the sampled steps whose estimate the tolerance held."""
    within = run.estimates.max(axis=1) <= tolerance
    return run.true[within].max(axis=1) / tolerance


def control_cell(run, tolerance):
    """Markdown cell: largest true error / tolerance, (mean substeps), how steps slipped.

    **UNDER** marks a step whose estimate the tolerance held but whose true error is more
    than FACTOR times the tolerance.
    """
    worst = run.true.max() / tolerance if run.true.size else math.nan
    text = f'{bench.scientific(worst, 1)} ({run.substeps:.3g})'
    if np.any(held(run, tolerance) > FACTOR):
        text = f'**{text} UNDER**'
    if run.capped:
        text += f', capped {run.capped}'
    if run.over:
        text += f', {run.over} kept above tol'
    return text + missing(run)


def control_summary(control, methods):
    """Markdown: per method and tolerance, the worst true error / tolerance over the cases.

    Only steps whose estimate was within the tolerance count (the others are those error
    control could not or did not split: capped, or kept above it); those are counted.
    """
    rows = []
    for method in methods:
        row = [method]
        for tolerance in TOLERANCES:
            runs = [run for (m, _, tol), run in control.items()
                    if m == method and tol == tolerance]
            worst = max((held(run, tolerance).max(initial=0.0) for run in runs), default=0.0)
            above = sum(run.over for run in runs)
            row.append(f'{bench.scientific(worst, 1)}; {above} of '
                       f'{sum(run.steps for run in runs)} kept above')
        rows.append(row)
    return bench.markdown_table(
        ['method'] + [f'tol {t:g}: worst true / tol; steps kept above tol' for t in TOLERANCES],
        rows)


def measure(keys, methods, samples, steps_cap=None):
    """Bare and error-controlled runs: {(method, key): Run}, {(method, key, tol): Run}."""
    bare, control = {}, {}
    for key in keys:
        probe = PROBES[key]
        steps = int(round(probe.duration / probe.dt))
        if steps_cap:
            steps = min(steps, steps_cap)
        for method in methods:
            bare[method, key] = sampled_run(probe.build(method), probe.dt, steps, samples)
            for tolerance in TOLERANCES:
                world = controlled(probe.build(method), tolerance)
                control[method, key, tolerance] = sampled_run(
                    world, probe.dt, min(steps, CONTROLLED_STEPS), samples)
            print(f'{key} {method}: {ratio_cell(bare[method, key])}', flush=True)
    return bare, control


def matrix(keys, methods, cell):
    """Markdown table, a row per case and a column per method, ``cell(method, key)``."""
    return bench.markdown_table(['case'] + list(methods),
                                [[key] + [cell(m, key) for m in methods] for key in keys])


def underestimates(bare):
    """Markdown list: each silent underestimate's worst tick in numbers."""
    lines = []
    for (method, key), run in bare.items():
        if flag(ratios(run)) != UNDER:
            continue
        ratio = np.nan_to_num(ratio_grid(run), nan=np.inf)
        tick, body = np.unravel_index(np.argmin(ratio), ratio.shape)
        lines.append(f'- **{method} on {key}**: estimate {run.estimates[tick, body]:.3g}, '
                     f'true {run.true[tick, body]:.3g} (ratio {ratio[tick, body]:.2g}); '
                     f'{np.sum(ratio < 1.0 / FACTOR)} of {len(ratios(run))} ticks below 1/'
                     f'{FACTOR:g}')
    return '\n'.join(lines) or '- none'


def family(method):
    """Return the integrator's family: the module its class is defined in."""
    return REGISTRY[method].__module__.rsplit('.', 1)[-1]


def plot(bare, path):
    """Log-log scatter of estimate against true error, a panel per family."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    families = sorted({family(method) for method, _ in bare})
    figure, axes = pyplot.subplots(1, len(families), figsize=(4.5 * len(families), 4.5),
                                   squeeze=False)
    line = np.array([1e-16, 1e2])
    for ax, name in zip(axes.flat, families):
        methods = [m for m in dict.fromkeys(m for m, _ in bare) if family(m) == name]
        for index, method in enumerate(methods):
            runs = [run for (m, _), run in bare.items() if m == method]
            true = np.concatenate([r.true.ravel() for r in runs])
            estimate = np.concatenate([r.estimates.ravel() for r in runs])
            ax.loglog(np.maximum(true, 1e-16), np.maximum(estimate, 1e-16), '.',
                      color=f'C{index}', markersize=3, label=method)
        ax.loglog(line, line, 'k-', linewidth=0.8)
        ax.fill_between(line, line / FACTOR, line * FACTOR, color='gray', alpha=0.2)
        ax.set(title=name, xlabel='true local error (scaled)', ylabel='estimate (scaled)',
               xlim=(1e-16, 1e2), ylim=(1e-16, 1e2))
        ax.grid(True, which='major', alpha=0.3)
        ax.legend(fontsize=7)
    figure.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    pyplot.close(figure)


def report(bare, control, keys, methods, plot_link, seconds, samples=SAMPLES):
    """Return the Markdown section."""
    parts = [
        '## Error estimates', f'Command: `{bench.command_line()}`',
        '\n'.join(bench.machine_description() + [f'- CPU time of the whole run: {seconds:.0f} s']),
        '### Estimate / true local error, bare methods',
        f'Median [min, max] over up to {samples} sampled ticks of each run, the case\'s dt, '
        'no substeps. Both errors are raised to the round-off floor, '
        f'{FLOOR:g} or {ROUND_OFF_ULPS} units in the last place of the position in sizes, '
        'whichever is larger; ticks where both are below it are left out. **UNDER**: some '
        f'tick\'s estimate is more than {FACTOR:g} times below the truth; over: more than '
        f'{FACTOR:g} times above. '
        f'Reference: DOP853 (rtol {ORACLE_RTOL:g}) from the same '
        'state over the same dt, its wrench the world\'s own effect sum.',
        matrix(keys, methods, lambda m, k: ratio_cell(bare[m, k])),
        '### Silent underestimates (worst tick)', underestimates(bare)]
    for tolerance in TOLERANCES:
        parts += [f'### Error control at tolerance {tolerance:g}: largest true error / '
                  'tolerance (mean substeps)',
                  f'At most {CONTROLLED_STEPS} steps of each case, auto_substep and '
                  'error_control on. capped: steps that needed more than the substep cap; '
                  'kept above tol: steps kept with an estimate above the tolerance; **UNDER**: '
                  f'a step within the tolerance by its estimate errs more than {FACTOR:g} '
                  'times it.',
                  matrix(keys, methods,
                         lambda m, k: control_cell(control[m, k, tolerance], tolerance))]
    parts += ['### Error control: worst true error / tolerance per method, over the steps '
              'whose estimate was within the tolerance', control_summary(control, methods)]
    if plot_link:
        parts += ['Estimate against true error of every sampled tick, a panel per family; '
                  f'the band is a factor {FACTOR:g} either way, points beyond 1e2 (diverged '
                  'bare runs) lie off the axes.',
                  f'![estimate against true error]({plot_link})']
    return '\n\n'.join(parts)


def add_arguments(parser):
    """Options of ``rigid_sim_bench estimates``."""
    parser.add_argument('--cases', nargs='+', choices=list(PROBES), default=list(PROBES))
    parser.add_argument('--methods', nargs='+', choices=sorted(REGISTRY), default=list(REGISTRY))
    parser.add_argument('--samples', type=int, default=SAMPLES, help='ticks sampled per run')
    parser.add_argument('--quick', action='store_true', help='a tiny configuration (seconds)')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')
    parser.add_argument('--plot', type=Path, help=f'plot file (default: {PLOT_NAME} by --out)')


def main(args):
    """Measure, print the Markdown report, write ``--out`` and the plot; (bare, control)."""
    keys, samples, cap = args.cases, args.samples, None
    if args.quick:
        keys = [k for k in keys if k in QUICK['cases']] or keys[:1]
        samples, cap = QUICK['samples'], QUICK['steps']
    start = time.process_time()
    bare, control = measure(keys, args.methods, samples, cap)
    plot_path = args.plot or (args.out.parent / PLOT_NAME if args.out else None)
    link = None
    if plot_path is not None:
        plot(bare, plot_path)
        link = plot_path.name if args.out and plot_path.parent == args.out.parent else plot_path
    text = report(bare, control, keys, args.methods, link, time.process_time() - start,
                  samples)
    print(text)
    if args.out:
        bench.write_section(args.out, SECTION, text)
    return bare, control
