# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench goals``: solving goals, against scipy's least_squares, in one run.

Per case, random reachable targets: the pose at T (2 s, or the case's) of the body flown
by the World itself (``World.step``) after a random change of its twist (or a random
wrench held). Each is solved from the unchanged body by
:class:`rigid_sim.core.goals.GoalSolver` and by ``scipy.optimize.least_squares``
(Levenberg-Marquardt, two-point differences) over the same one-copy flights, from the same
first iterate. Both solutions are then flown by a fresh World, whose distance from the
target is the final error; solved means within 1e-9 m and 1e-9 rad. Nearest means no
farther from the current motion than the known change that made the target, by the
solver's metric (``GoalProblem.distance``), to 1e-6 of it. CPU time is
``time.process_time`` around each solve.
"""
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from scipy.optimize import least_squares

from rigid_sim import bench
from rigid_sim.core.rotation import angle_between
from rigid_sim.core.body_state import body_frame_state, with_twist
from rigid_sim.core.scene import build_world, parse_scene
from rigid_sim.core.goals import ACCEPTED, Goal, GoalRefused, GoalSolver
from rigid_sim.core.goal_problem import GoalProblem

SECTION = 'rigid_sim_bench goals'
HORIZON = 2.0        # s from the start to the goal
PLOT_NAME = 'goals_trajectory.png'
BOX = {'name': 'box', 'shape': {'type': 'box', 'size': [0.2, 0.3, 0.4]}, 'mass': 2.0,
       'pose': {'position': [0.3, 0.0, 0.5]},
       'twist': {'linear': [0.1, 0.0, 0.0], 'angular': [1.0, 2.0, 3.0]}}
SPRING = {'body': 'box', 'point': [0.02, 0.02, 0.02], 'anchor': [0.0, 0.0, 1.0],
          'stiffness': 8.0, 'damping': 0.2}


@dataclass(frozen=True)
class Case:
    """One benchmark case: a one-body scene, its step and unknowns, how targets are drawn."""

    key: str
    title: str
    effects: dict
    time_step: float    # s; None: the whole flight is one step (exact free flow)
    unknowns: str = 'twist'
    spread: tuple = (0.5, 0.5)   # std. dev. of the twist change (m/s, rad/s) or wrench (N, N m)
    horizon: float = HORIZON     # s from the start to the goal
    spin: tuple = (1.0, 2.0, 3.0)   # rad/s, the box's angular velocity before the change
    baseline: bool = True        # also solved by least_squares (too slow on long flights)


CASES = (
    Case('tumbling', 'torque-free box tumbling at (1, 2, 3) rad/s, exact flow', {}, None),
    Case('gravity', 'the same under gravity', {'gravity': {'acceleration': [0, 0, -9.81]}},
         None),
    Case('damping', 'linear and angular damping (0.5, 0.3 1/s), dt 1e-3',
         {'damping': {'linear': 0.5, 'angular': 0.3}}, 1e-3),
    Case('springs', 'a damped spring 0.035 m off the centre of mass, dt 1e-3',
         {'springs': [SPRING]}, 1e-3),
    Case('springs_lever', 'the spring 0.087 m off: its torque swings the box hard, dt 1e-3',
         {'springs': [dict(SPRING, point=[0.05, 0.05, 0.05])]}, 1e-3),
    Case('wrench', 'gravity, unknowns a wrench held until T (world axes), dt 1e-3',
         {'gravity': {'acceleration': [0, 0, -9.81]}}, 1e-3, 'wrench', (1.0, 0.01)),
    Case('spinning', 'torque-free box tumbling fast, at (10, 15, 15) rad/s (23.5): goals '
         'with several solutions a whole turn apart, exact flow', {}, None,
         spin=(10.0, 15.0, 15.0)),
    Case('springs_long', 'the damped spring of `springs`, T = 10 s, dt 1e-2',
         {'springs': [SPRING]}, 1e-2, horizon=10.0, baseline=False),
    Case('tumbling_long', 'the torque-free box of `tumbling`, T = 10 s, exact flow', {},
         None, horizon=10.0, baseline=False),
    Case('damping_long', 'the damping of `damping`, T = 10 s, dt 1e-2',
         {'damping': {'linear': 0.5, 'angular': 0.3}}, 1e-2, horizon=10.0, baseline=False),
    Case('wrench_long', 'the wrench unknowns of `wrench`, T = 10 s, dt 1e-2',
         {'gravity': {'acceleration': [0, 0, -9.81]}}, 1e-2, 'wrench', (1.0, 0.01),
         horizon=10.0, baseline=False),
)
CASES_BY_KEY = {case.key: case for case in CASES}
DEFAULT_CASES = ('tumbling', 'gravity', 'damping', 'springs', 'wrench', 'spinning')
TARGETS = 200
QUICK = 2   # targets of --quick


def world_of(case):
    """Return a fresh World of the case's one-body scene, with exact_split."""
    box = dict(BOX, twist={'linear': BOX['twist']['linear'], 'angular': list(case.spin)})
    scene = {'effects': case.effects, 'bodies': [box]}
    return build_world(parse_scene(yaml.safe_load(yaml.safe_dump(scene))), 'exact_split')


def fly(case, change):
    """Return the body's final state (13,) after the horizon with ``change``, by World.step.

    ``change``: (6,) twist (origin velocity, angular velocity) or wrench (force, torque).
    """
    world = world_of(case)
    if case.unknowns == 'wrench':
        world.inputs.hold(0, 'goal', 'world', change[:3], change[3:], expires=case.horizon)
    else:
        world.y = with_twist(world.bodies, world.y, 0, change[:3], change[3:])
    steps = 1 if case.time_step is None else round(case.horizon / case.time_step)
    for _ in range(steps):
        world.step(case.horizon / steps)
    return world.y[0]


def draw_targets(case, count, rng):
    """``count`` (goal, known unknowns) reached by random changes of the current twist.

    Or by a random wrench held.
    """
    world = world_of(case)
    _, _, velocity, spin = body_frame_state(world.bodies, world.y, 0)
    base = np.zeros(6) if case.unknowns == 'wrench' else np.concatenate((velocity, spin))
    goals = []
    for _ in range(count):
        change = base + np.repeat(case.spread, 3) * rng.normal(size=6)
        final = fly(case, change)   # the box's centre of mass is its frame's origin
        goals.append((Goal(0, final[:3].copy(), final[3:7].copy(), case.horizon,
                           case.unknowns), change))
    return goals


def final_errors(case, goal, values):
    """Position (m) and orientation (rad) errors of a fresh World flown with ``values``."""
    final = fly(case, values)
    return (float(np.linalg.norm(final[:3] - goal.position)),
            float(angle_between(final[None, 3:7], goal.orientation[None])[0]))


def ours(solver, goal):
    """Solve with GoalSolver: (values or None, iterations, CPU seconds)."""
    started = time.process_time()
    try:
        solution = solver.solve(goal)
    except GoalRefused:
        return None, 0, time.process_time() - started
    seconds = time.process_time() - started
    values = solution.wrench if solution.wrench is not None else np.concatenate(
        (solution.linear_velocity, solution.angular_velocity))
    return values, solution.iterations, seconds


def baseline(solver, goal):
    """Solve with least_squares over the fine one-copy flights: (values, evaluations, s)."""
    started = time.process_time()
    problem = GoalProblem(solver, goal, np.asarray(goal.position), goal.orientation)
    problem.fly_on(problem.fine)
    result = least_squares(lambda u: problem.residuals(u[None])[0], problem.first_iterate(),
                           jac='2-point', method='lm', xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return result.x, result.nfev, time.process_time() - started


METHODS = {'GoalSolver': ours, 'least_squares': baseline}
NEAREST_SLACK = 1e-6   # relative: a solution this much farther than the known one is as near


@dataclass
class Row:
    """What one method did on one case's targets."""

    solved: int = 0
    nearest: int = 0         # solved no farther than the known change, by the metric
    farther: float = 1.0     # the largest distance of a solution over the known one's
    errors: list = None      # max(position m, orientation rad) per target
    counts: list = None      # iterations (ours) or residual evaluations (baseline)
    seconds: list = None     # CPU seconds per solve


def run_case(case, targets, rng):
    """Rows of both methods on ``targets`` goals of ``case``, interleaved target by target."""
    world = world_of(case)
    solver = GoalSolver(world, case.time_step)
    methods = {name: method for name, method in METHODS.items()
               if case.baseline or method is ours}
    for method in methods.values():   # compile and build the copies before timing
        method(solver, draw_targets(case, 1, rng)[0][0])
    rows = {name: Row(0, 0, 1.0, [], [], []) for name in methods}
    for goal, known in draw_targets(case, targets, rng):
        problem = GoalProblem(solver, goal, np.asarray(goal.position), goal.orientation)
        for name, method in methods.items():
            values, count, seconds = method(solver, goal)
            row = rows[name]
            row.seconds.append(seconds)
            row.counts.append(count)
            error = np.inf if values is None else max(final_errors(case, goal, values))
            row.errors.append(error)
            row.solved += error <= ACCEPTED
            if error <= ACCEPTED:
                ratio = problem.distance(values) / problem.distance(known)
                row.nearest += bool(ratio <= 1.0 + NEAREST_SLACK)
                row.farther = max(row.farther, ratio)
    return rows


def table(results, targets):
    """Markdown: a row per case and method."""
    header = ['case', 'method', f'solved (of {targets})', 'nearest', 'distance / known, worst',
              'final error, median',
              'final error, worst solved', 'iterations or evaluations, median',
              'CPU median [ms]', 'CPU p99 [ms]']
    lines = []
    for key, rows in results.items():
        for name, row in rows.items():
            errors = np.array(row.errors)
            solved = errors[errors <= ACCEPTED]
            lines.append([key, name, row.solved, row.nearest, f'{row.farther:.3g}',
                          bench.scientific(float(np.median(errors))),
                          bench.scientific(float(solved.max())) if solved.size else '-',
                          f'{np.median(row.counts):g}',
                          f'{1e3 * np.median(row.seconds):.2f}',
                          f'{1e3 * np.percentile(row.seconds, 99):.2f}'])
    return bench.markdown_table(header, lines)


def plot(path):
    """Plot a solved springs goal: the body frame's path and its angle to the goal."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    case = CASES_BY_KEY['springs']
    goal = draw_targets(case, 1, np.random.default_rng(7))[0][0]
    solution = GoalSolver(world_of(case), case.time_step).solve(goal, path=True)
    times, origins, orientations = solution.path
    figure, (left, right) = pyplot.subplots(1, 2, figsize=(11, 4))
    for axis, name in enumerate('xyz'):
        left.plot(times, origins[:, axis], color=f'C{axis}', label=f'{name} (m)')
        left.plot(solution.arrival, goal.position[axis], 'o', color=f'C{axis}',
                  markerfacecolor='none', markersize=10)
    left.set_xlabel('simulated time (s)')
    left.set_title('solved path of the body frame origin; circles: the goal')
    left.legend()
    wanted = np.broadcast_to(goal.orientation, orientations.shape)
    angles = angle_between(orientations, wanted)
    right.semilogy(times, np.maximum(angles, 1e-16))
    right.set_xlabel('simulated time (s)')
    right.set_title('angle to the goal orientation (rad)')
    figure.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    pyplot.close(figure)


def add_arguments(parser):
    """Options of ``rigid_sim_bench goals``."""
    parser.add_argument('--cases', nargs='+', choices=list(CASES_BY_KEY),
                        default=list(DEFAULT_CASES))
    parser.add_argument('--targets', type=int, default=TARGETS, help='targets per case')
    parser.add_argument('--quick', action='store_true', help=f'{QUICK} targets per case')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Solve every case's targets both ways, print the report, write ``--out``; the rows."""
    targets = QUICK if args.quick else args.targets
    rng = np.random.default_rng(2026)
    results = {key: run_case(CASES_BY_KEY[key], targets, rng) for key in args.cases}
    link = None
    if args.out is not None:
        plot(args.out.parent / PLOT_NAME)
        link = PLOT_NAME
    cases = '\n'.join(f'- `{case.key}`: {case.title}; targets {case.horizon:g} s ahead from '
                      f'a change of {"wrench" if case.unknowns == "wrench" else "twist"} '
                      f'with std. dev. {case.spread[0]:g}, {case.spread[1]:g} per axis'
                      for case in CASES if case.key in args.cases)
    parts = ['## Goals: solve time and accuracy', f'Command: `{bench.command_line()}`',
             '\n'.join(bench.machine_description()), cases, table(results, targets)]
    if link:
        parts.append(f'![a solved springs goal]({link})')
    text = '\n\n'.join(parts)
    print(text)
    if args.out is not None:
        bench.write_section(args.out, SECTION, text)
    return results
