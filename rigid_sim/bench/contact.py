# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench contact``: contact scenes against closed forms and MuJoCo, in one run.

Four scenes, each simulated by rigid_sim's contact stage and by MuJoCo (the version is
recorded) with the same time step:

- **slide at 45 degrees**: a 0.2 m cube leaves at ``v0`` at 45 degrees to the world axes
  (a pyramidal cone's edges) on ground of friction ``mu``; the distance to the stop against
  ``v0^2 / (2 mu g)``. MuJoCo with its default pyramidal cone and with its elliptic cone.
- **stack of 10 boxes** for 10 s: largest horizontal drift and largest overlap.
- **1000 spheres poured into a box** (a floor and four walls): wall time per step (median
  of blocks of steps, ``time.perf_counter``) and the largest overlap at the end.
- **bounce**: a ball dropped from ``h0`` with restitution ``e``; the largest relative error
  of its first apexes against ``e^(2k) h0`` and the mean wall time per step (interleaved
  blocks), in rigid_sim's velocity and exact contact modes. MuJoCo has no restitution
  coefficient: its contact is made a damped spring whose half period loses the energy of
  ``e`` (``solref`` of stiffness ``(2 pi / T)^2`` and damping ``2 zeta (2 pi / T)``, ``T``
  MuJoCo's default time constant).
"""
import math
import sys
import time

import numpy as np
from scipy.spatial import cKDTree

from rigid_sim import bench
from rigid_sim.core.scene import build_world, parse_scene
from rigid_sim.core.warm_up import warm_up

try:
    import mujoco
except ImportError:   # optional: the bench extra
    mujoco = None

SECTION = 'rigid_sim_bench contact'
G, MU, V0, EDGE = 9.81, 0.3, 2.0, 0.2
SLIDE_DT, STACK_DT, POUR_DT = 1e-3, 5e-3, 5e-3
STACK_TIME, STACK_ITERATIONS = 10.0, 200
SPHERES, RADIUS, HALF_WIDTH = 1000, 0.05, 0.6
BOUNCE_E, BOUNCE_H0, BOUNCE_DT, BOUNCE_APEXES = 0.8, 1.0, 1e-3, 4
BOUNCE_RESTING_SPEED = 0.02   # m/s: below the fourth rebound's speed
MUJOCO_TIME_CONSTANT = 0.02   # s, MuJoCo's default solref time constant
FULL = dict(pour_steps=400, block=20)
QUICK = dict(pour_steps=40, block=10, spheres=64, stack_time=0.5)
GROUND = {'normal': [0.0, 0.0, 1.0], 'offset': 0.0}
WALLS = [GROUND] + [{'normal': normal, 'offset': -HALF_WIDTH}
                    for normal in ([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                                   [0.0, -1.0, 0.0])]


def rigid_world(bodies, planes, **contact):
    """World of scene ``bodies`` under gravity on ``planes``."""
    return build_world(parse_scene({'effects': {
        'gravity': {'acceleration': [0.0, 0.0, -G]},
        'contact': {'planes': planes, **contact}}, 'bodies': bodies}))


def cube(name, position, linear=(0.0, 0.0, 0.0)):
    return {'name': name, 'shape': {'type': 'box', 'size': [EDGE] * 3}, 'mass': 1.0,
            'pose': {'position': list(position)}, 'twist': {'linear': list(linear)}}


def mujoco_model(bodies, cone='pyramidal', dt=1e-3, walls=False):
    """MJCF of free bodies (name, 'box' or 'sphere', position) on the ground (and walls)."""
    planes = '<geom type="plane" size="0 0 1" friction="{mu} 0.005 0.0001"/>'
    if walls:
        for axis, sign in ((0, 1), (0, -1), (1, 1), (1, -1)):
            position = [0.0, 0.0, 0.0]
            position[axis] = -sign * HALF_WIDTH
            normal = [0.0, 0.0, 0.0]
            normal[axis] = sign
            planes += (f'<geom type="plane" size="0 0 1" pos="{" ".join(map(str, position))}" '
                       f'zaxis="{" ".join(map(str, normal))}" friction="{{mu}} 0.005 0.0001"/>')
    geoms = []
    for name, kind, position in bodies:
        size = f'{EDGE / 2} {EDGE / 2} {EDGE / 2}' if kind == 'box' else str(RADIUS)
        geoms.append(f'<body name="{name}" pos="{" ".join(map(str, position))}"><freejoint/>'
                     f'<geom type="{kind}" size="{size}" mass="1" friction="{{mu}} 0.005 '
                     '0.0001"/></body>')
    xml = (f'<mujoco><option timestep="{dt}" gravity="0 0 {-G}" cone="{cone}"/><worldbody>'
           + planes + ''.join(geoms) + '</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml.replace('{mu}', str(MU)))
    return model, mujoco.MjData(model)


def slide():
    """Stop distance at 45 degrees: relative error of rigid_sim and MuJoCo's two cones."""
    direction = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    expected = V0 ** 2 / (2 * MU * G)
    steps = int(2.0 * V0 / (MU * G) / SLIDE_DT)
    world = rigid_world([cube('block', (0.0, 0.0, EDGE / 2), V0 * direction)], [GROUND],
                        friction=MU)
    start = world.y[0, :3].copy()
    for _ in range(steps):
        world.step(SLIDE_DT)
    errors = {'rigid_sim': (world.y[0, :3] - start) @ direction / expected - 1.0}
    for cone in ('pyramidal', 'elliptic'):
        model, data = mujoco_model([('block', 'box', (0.0, 0.0, EDGE / 2))], cone, SLIDE_DT)
        data.qvel[0:3] = V0 * direction
        start = data.qpos[0:3].copy()
        mujoco.mj_step(model, data, nstep=steps)
        errors[f'MuJoCo {cone}'] = (data.qpos[0:3] - start) @ direction / expected - 1.0
    return errors


def stack(duration):
    """Largest drift and overlap of 10 stacked boxes over ``duration``, and ms per step."""
    steps = int(round(duration / STACK_DT))
    places = [(0.0, 0.0, EDGE * (k + 0.5)) for k in range(10)]
    world = rigid_world([cube(f'b{k}', p) for k, p in enumerate(places)], [GROUND],
                        friction=MU, iterations=STACK_ITERATIONS)
    model, data = mujoco_model([(f'b{k}', 'box', p) for k, p in enumerate(places)],
                               dt=STACK_DT)
    start = np.array(places)
    results = {}
    for name, advance, position in (
            ('rigid_sim', lambda: world.step(STACK_DT), lambda: world.y[:, :3]),
            (f'MuJoCo {mujoco.__version__}', lambda: mujoco.mj_step(model, data),
             lambda: data.qpos.reshape(10, 7)[:, :3])):
        overlap, clock = 0.0, time.perf_counter()
        for _ in range(steps):
            advance()
            z = position()[:, 2]
            overlap = max(overlap, -(z[0] - EDGE / 2), -np.min(np.diff(z) - EDGE))
        elapsed = time.perf_counter() - clock
        drift = np.max(np.abs(position() - start))
        results[name] = (drift, overlap, 1e3 * elapsed / steps)
    return results


def sphere_places(count):
    """Return a grid of ``count`` sphere centres above the box's floor, 2.2 radii apart."""
    across = int((2 * HALF_WIDTH - 2 * RADIUS) / (2.2 * RADIUS))
    return [((k % across - (across - 1) / 2) * 2.2 * RADIUS,
             ((k // across) % across - (across - 1) / 2) * 2.2 * RADIUS,
             RADIUS * 1.5 + (k // (across * across)) * 2.2 * RADIUS) for k in range(count)]


def largest_overlap(centres):
    """Largest overlap of spheres with each other and with the floor and walls, m."""
    pairs = cKDTree(centres).query_pairs(2 * RADIUS, output_type='ndarray')
    between = 2 * RADIUS - np.linalg.norm(centres[pairs[:, 0]] - centres[pairs[:, 1]], axis=1)
    walls = np.max(np.abs(centres[:, :2])) + RADIUS - HALF_WIDTH
    floor = RADIUS - np.min(centres[:, 2])
    return max(0.0, walls, floor, between.max() if len(between) else 0.0)


def pour(count, steps, block):
    """Median ms per step of each simulator pouring ``count`` spheres, and the overlap."""
    places = sphere_places(count)
    world = rigid_world([{'name': f's{k}', 'shape': {'type': 'sphere', 'radius': RADIUS},
                          'mass': 1.0, 'pose': {'position': list(p)}}
                         for k, p in enumerate(places)], WALLS, friction=MU)
    model, data = mujoco_model([(f's{k}', 'sphere', p) for k, p in enumerate(places)],
                               dt=POUR_DT, walls=True)
    times = {'rigid_sim': [], f'MuJoCo {mujoco.__version__}': []}
    runs = (lambda: world.step(POUR_DT), lambda: mujoco.mj_step(model, data))
    for _ in range(steps // block):   # interleaved blocks: both see the same load
        for name, advance in zip(times, runs):
            clock = time.perf_counter()
            for _ in range(block):
                advance()
            times[name].append(1e3 * (time.perf_counter() - clock) / block)
    ends = (world.y[:, :3], data.qpos.reshape(count, 7)[:, :3])
    return {name: (float(np.median(times[name])), largest_overlap(np.array(end)))
            for name, end in zip(times, ends)}


def apexes(heights, speeds):
    """Apexes of the flights in a run's (height, vertical speed) samples.

    Each is read at the last sample before the speed turned downward, above the ground (so
    in free flight, also for MuJoCo's soft contact), by projectile motion:
    ``height + speed^2 / (2 g)``.
    """
    found, last = [], (0.0, 0.0)
    for height, speed in zip(heights, speeds):
        if last[1] > 0.0 >= speed and last[0] > 0.0:
            found.append(last[0] + last[1] * last[1] / (2 * G))
        last = (height, speed)
    return found


def apex_error(found):
    """Largest relative error of the first BOUNCE_APEXES apexes against ``e^(2k) h0``."""
    errors = [a / (BOUNCE_E ** (2 * k) * BOUNCE_H0) - 1.0
              for k, a in enumerate(found[:BOUNCE_APEXES], start=1)]
    if len(errors) < BOUNCE_APEXES:
        return math.nan   # fewer rebounds than asked for
    return max(errors, key=abs)


def mujoco_bounce_model():
    """MJCF of the dropped ball, its contact a damped spring of restitution BOUNCE_E."""
    log_e = math.log(BOUNCE_E)
    zeta = -log_e / math.sqrt(math.pi ** 2 + log_e ** 2)   # e = exp(-pi zeta / sqrt(1-zeta^2))
    omega = 2 * math.pi / MUJOCO_TIME_CONSTANT
    xml = (f'<mujoco><option timestep="{BOUNCE_DT}" gravity="0 0 {-G}"/><worldbody>'
           '<geom type="plane" size="0 0 1"/>'
           f'<body pos="0 0 {RADIUS + BOUNCE_H0}"><freejoint/>'
           f'<geom type="sphere" size="{RADIUS}" mass="1" '
           f'solref="{-omega * omega} {-2 * zeta * omega}"/></body></worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def bounce(block):
    """Apex error and mean ms per step of the drop: rigid_sim's two modes and MuJoCo."""
    t0 = math.sqrt(2 * BOUNCE_H0 / G)
    # Past the flight that ends in impact BOUNCE_APEXES + 1: t0 (1 + 2e + ... + 2e^k).
    duration = t0 * (1 + 2 * sum(BOUNCE_E ** k for k in range(1, BOUNCE_APEXES + 1)))
    steps = block * math.ceil(duration / BOUNCE_DT / block)
    ball = {'name': 'ball', 'shape': {'type': 'sphere', 'radius': RADIUS}, 'mass': 1.0,
            'pose': {'position': [0.0, 0.0, RADIUS + BOUNCE_H0]}}
    runs = {}
    for mode in ('velocity', 'exact'):
        world = rigid_world([ball], [GROUND], restitution=BOUNCE_E, mode=mode,
                            resting_speed=BOUNCE_RESTING_SPEED)
        warm_up(world)   # the kernels' loading is not a step's time
        runs[f'rigid_sim, mode {mode}'] = (lambda w=world: w.step(BOUNCE_DT),
                                           lambda w=world: (w.y[0, 2] - RADIUS, w.y[0, 9]))
    model, data = mujoco_bounce_model()
    runs[f'MuJoCo {mujoco.__version__}'] = (lambda: mujoco.mj_step(model, data),
                                            lambda: (data.qpos[2] - RADIUS, data.qvel[2]))
    samples = {name: [] for name in runs}
    seconds = dict.fromkeys(runs, 0.0)
    for _ in range(steps // block):   # interleaved blocks: all see the same load
        for name, (advance, read) in runs.items():
            clock = time.perf_counter()
            for _ in range(block):
                advance()
                samples[name].append(read())
            seconds[name] += time.perf_counter() - clock
    # The reads are inside the timed blocks of every simulator alike: a few percent of a
    # step, the same cost in each.
    return {name: (apex_error(apexes(*zip(*samples[name]))), 1e3 * seconds[name] / steps)
            for name in runs}


def add_arguments(parser):
    """Options of ``rigid_sim_bench contact``."""
    parser.add_argument('--quick', action='store_true', help='small scenes, for tests')
    parser.add_argument('--out', help='Markdown file whose section is (re)written')
    parser.add_argument('--plot', help='PNG file of the time per step and the slide errors')


def main(args):
    """Measure, print the Markdown report, write ``--out`` and ``--plot``; the results."""
    if mujoco is None:
        raise bench.MissingPackage('contact compares with MuJoCo: pip install mujoco')
    chosen = QUICK if args.quick else FULL
    count = chosen.get('spheres', SPHERES)
    results = {'slide': slide(), 'stack': stack(chosen.get('stack_time', STACK_TIME)),
               'pour': pour(count, chosen['pour_steps'], chosen['block']),
               'bounce': bounce(chosen['block'])}
    print(results, file=sys.stderr)
    load = open('/proc/loadavg').read().split()[:3] if sys.platform == 'linux' else ['?']
    text = '\n'.join([
        '### Setup', *[line for line in bench.machine_description([f'MuJoCo {mujoco.__version__}'])
                       if not line.startswith('- CPU time')],
        '- Time: `time.perf_counter` around the steps (wall time; the pour: median of '
        'interleaved blocks; the bounce: mean of interleaved blocks)',
        f'- Load average at the end (1, 5, 15 min): {" ".join(load)}',
        f'- Command: `{bench.command_line()}`',
        f'- rigid_sim: default integrator, contact iterations 30 (stack: '
        f'{STACK_ITERATIONS}); MuJoCo: default solver (Newton), same time steps.',
        '', f'### Slide at 45 degrees (mu {MU}, v0 {V0} m/s, dt {SLIDE_DT:g} s)',
        bench.markdown_table(['simulator', 'stop distance error'],
                             [[name, f'{100 * error:+.2f} %']
                              for name, error in results['slide'].items()]),
        '', f'### Stack of 10 boxes ({chosen.get("stack_time", STACK_TIME):g} s, dt '
        f'{STACK_DT:g} s)',
        bench.markdown_table(['simulator', 'largest drift', 'largest overlap', 'ms per step'],
                             [[name, f'{1e3 * d:.3g} mm', f'{1e3 * o:.3g} mm', f'{ms:.3g}']
                              for name, (d, o, ms) in results['stack'].items()]),
        '', f'### {count} spheres poured into a box (dt {POUR_DT:g} s, '
        f'{chosen["pour_steps"]} steps)',
        bench.markdown_table(['simulator', 'ms per step (median)', 'overlap at the end'],
                             [[name, f'{ms:.3g}', f'{1e3 * o:.3g} mm']
                              for name, (ms, o) in results['pour'].items()]),
        '', f'### Bounce (e {BOUNCE_E}, h0 {BOUNCE_H0:g} m, dt {BOUNCE_DT:g} s, resting speed '
        f'{BOUNCE_RESTING_SPEED:g} m/s)',
        bench.markdown_table(['simulator', f'largest apex error, first {BOUNCE_APEXES}',
                              'ms per step (mean)'],
                             [[name, f'{error:+.2e}', f'{ms:.3g}']
                              for name, (error, ms) in results['bounce'].items()])])
    print(text)
    if args.out is not None:
        bench.write_section(args.out, SECTION, text)
    if args.plot is not None:
        plot(results, args.plot)
    return results


def plot(results, path):
    """Two panels: the slide's error per simulator, the pour's ms per step."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    figure, (left, right) = pyplot.subplots(1, 2, figsize=(10, 4))
    names = list(results['slide'])
    left.bar(names, [100 * abs(e) for e in results['slide'].values()])
    left.set_ylabel('|stop distance error|, %')
    left.set_title('slide at 45 degrees')
    names = list(results['pour'])
    right.bar(names, [ms for ms, _ in results['pour'].values()])
    right.set_ylabel('ms per step (median)')
    right.set_title('spheres poured into a box')
    figure.tight_layout()
    figure.savefig(path, dpi=100)
