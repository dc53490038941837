# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench inertia``: inertia-tensor estimates, their error and their time.

Bounding box, point sampling (plain random and scrambled Sobol, N = 1e2 .. 1e6) and the exact
polyhedral integral, on a non-convex torus and on a sphere mesh. The error is the relative
Frobenius norm ``|I - I_ref|_F / |I_ref|_F``; references are the exact tensor of the same
mesh and, for the sphere, the analytic ``2/5 M R^2``.
"""
import time
from pathlib import Path

import numpy as np
import trimesh

from rigid_sim import bench
from rigid_sim.core import inertia

MASS = 1.0                # kg
SAMPLE_COUNTS = tuple(10 ** k for k in range(2, 7))
SEQUENCES = ('random', 'sobol')
REPEATS = 5               # timed runs per estimate (sampling: one seed each); medians shown
BUDGET = 60.0             # CPU s per estimate, all repeats (or one run); costlier N skipped
QUICK = dict(counts=(100, 1000), repeats=1)
SECTION = 'rigid_sim_bench inertia'
SPHERE_RADIUS = 0.5       # m
TORUS_RADII = (0.5, 0.15)  # m, major and minor: a hole, so non-convex


def shapes():
    """(name, mesh, analytic tensor or None) of the benchmark shapes."""
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=SPHERE_RADIUS)
    torus = trimesh.creation.torus(major_radius=TORUS_RADII[0], minor_radius=TORUS_RADII[1])
    ball = 0.4 * MASS * SPHERE_RADIUS ** 2 * np.eye(3)
    return (('torus', torus, None), ('sphere', sphere, ball))


def relative_error(estimate, reference):
    """``|estimate - reference|_F / |reference|_F`` of (3, 3) tensors."""
    return float(np.linalg.norm(estimate - reference) / np.linalg.norm(reference))


def measure(estimator, repeats):
    """Median CPU time of ``estimator(seed).inertia`` over seeds 0 .. repeats-1; the tensors."""
    times, tensors = [], []
    for seed in range(repeats):
        start = time.process_time()
        tensors.append(estimator(seed).inertia)
        times.append(time.process_time() - start)
    return float(np.median(times)), tensors


def estimators(mesh, counts):
    """(label, N or None, estimator(seed)) for every method to compare."""
    listed = [('exact', None, lambda seed: inertia.mesh_exact(mesh, mass=MASS)),
              ('bounding box', None, lambda seed: inertia.bounding_box_estimate(mesh, mass=MASS))]
    for sequence in SEQUENCES:
        for count in counts:
            listed.append((f'sampling {sequence}', count,
                           lambda seed, s=sequence, n=count: inertia.sampling_estimate(
                               mesh, n, sequence=s, seed=seed, mass=MASS)))
    return listed


def planned_runs(label, count, previous, repeats, budget):
    """Return the runs to time for the next sample count (0: skip it) and seconds per run.

    Cost grows in proportion to N. When ``repeats`` runs would exceed the budget but one
    fits, one run is timed: a run that long varies far less than between methods.
    """
    if label not in previous:
        return repeats, 0.0
    last_count, last_time = previous[label]
    estimate = last_time * count / last_count
    if estimate * repeats <= budget:
        return repeats, estimate
    return (1 if estimate <= budget else 0), estimate


def rows_for(name, mesh, analytic, counts, repeats, budget):
    """Table rows of one shape, and notes on the sample counts skipped for time."""
    exact = inertia.mesh_exact(mesh, mass=MASS).inertia
    rows, skipped, previous = [], [], {}
    for label, count, estimator in estimators(mesh, counts):
        runs, estimate = planned_runs(label, count, previous, repeats, budget)
        if runs == 0:
            skipped.append(f'{name} / {label} / N = {count:.0e}: estimated {estimate:.0f} s '
                           f'per run > budget {budget:g} s')
            continue
        cpu_time, tensors = measure(estimator, runs)
        if count is not None:
            previous[label] = (count, cpu_time)
        errors = [relative_error(t, exact) for t in tensors]
        against = ([relative_error(t, analytic) for t in tensors] if analytic is not None
                   else [np.nan])
        rows.append((name, label, '-' if count is None else f'{count:.0e}', runs,
                     bench.scientific(float(np.median(errors))),
                     bench.scientific(float(np.median(against))), f'{1e3 * cpu_time:.3g}'))
    return rows, skipped


def report(counts, repeats, budget):
    """Return the Markdown section of the inertia benchmark."""
    rows, skipped = [], []
    for name, mesh, analytic in shapes():
        shape_rows, shape_skipped = rows_for(name, mesh, analytic, counts, repeats, budget)
        rows += shape_rows
        skipped += shape_skipped
    header = ('shape', 'method', 'N', 'runs', 'error vs exact mesh (rel)',
              'error vs analytic (rel)', 'CPU (ms)')
    parts = ['## Inertia estimates: error against CPU time',
             f'Command: `{bench.command_line()}`',
             '\n'.join(bench.machine_description([f'trimesh {trimesh.__version__}'])),
             f'Mass {MASS:g} kg; torus radii {TORUS_RADII} m, icosphere (subdivisions 4) of '
             f'radius {SPHERE_RADIUS} m. Sampling: medians over seeds 0, 1, .. (one per run).',
             bench.markdown_table(header, rows)]
    if skipped:
        parts += ['Not run:', '\n'.join('- ' + note for note in skipped)]
    return '\n\n'.join(parts)


def add_arguments(parser):
    """Options of ``rigid_sim_bench inertia``."""
    parser.add_argument('--quick', action='store_true', help='N = 1e2, 1e3 and one run')
    parser.add_argument('--repeats', type=int, default=REPEATS, help='timed runs (seeds)')
    parser.add_argument('--budget', type=float, default=BUDGET,
                        help='CPU seconds per estimate (all repeats); costlier N are skipped')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Print the inertia table and write its section into ``--out``."""
    counts, repeats = ((QUICK['counts'], QUICK['repeats']) if args.quick
                       else (SAMPLE_COUNTS, args.repeats))
    text = report(counts, repeats, args.budget)
    print(text)
    if args.out:
        bench.write_section(args.out, SECTION, text)
    return text
