# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench stability``: the hard cases, run long, through every integrator.

Each case is a world with a known energy history (constant, or ``exp(-2 c t)`` under
momentum damping) and known invariants. Every registered integrator runs it bare
(``auto_substep=False``) and the default one also with its safeguards; the outcome table
is printed and, with ``--out``, written into a Markdown file (``docs/stability.md``).
``test/test_stability.py`` runs short versions.
"""
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigid_sim import bench
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import SpringSpec, Springs
from rigid_sim.core.integrators import DEFAULT_INTEGRATOR, REGISTRY
from rigid_sim.core.safeguards import ENERGY_RTOL
from rigid_sim.core.state import ANGULAR_MOMENTUM, ORIENTATION, RigidBodies, initial_state
from rigid_sim.core.world import World

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])
TILTED = np.array([0.1, -0.2, 0.3, 0.9273618495495703])   # unit (x, y, z, w), generic
NORM_RTOL = 1e-12     # |L| (torque-free) and |q| must hold to this
DAMPING_RATE = 0.5    # 1/s, linear and angular, in the damped case
LONG_RUN_BODIES = 100  # the test's long run: bodies advanced together (see docs/stability.md)
SECTION = 'rigid_sim_bench stability'


def world(moments, omega, effects=(), integrator=DEFAULT_INTEGRATOR, auto_substep=True,
          mass=1.0, scale=1.0, position=(0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0),
          orientation=IDENTITY, com=(0.0, 0.0, 0.0), inputs=None):
    """Return a world of bodies with principal moments ``mass scale^2 moments`` (N, 3), kg m^2.

    ``effects`` is a list of callables ``bodies -> effect``, ``inputs`` one
    ``bodies -> AppliedWrenches`` (None: no input); ``omega`` (N, 3) rad/s, world.
    """
    moments = np.atleast_2d(np.asarray(moments, dtype=float))
    count = len(moments)
    mass = np.broadcast_to(np.asarray(mass, dtype=float), (count,)).copy()
    inertia = np.einsum('n,ni,ij->nij', mass * scale ** 2, moments, np.eye(3))
    bodies = RigidBodies(tuple(f'b{i}' for i in range(count)), mass, inertia,
                         np.broadcast_to(np.asarray(com, float), (count, 3)).copy())

    def rows(value, width):
        return np.broadcast_to(np.asarray(value, dtype=float), (count, width))
    y0 = initial_state(bodies, rows(position, 3), rows(orientation, 4), rows(velocity, 3),
                       rows(omega, 3))
    return World(bodies, y0, [make(bodies) for make in effects], integrator,
                 auto_substep=auto_substep, inputs=None if inputs is None else inputs(bodies),
                 error_control=auto_substep)


def spring(stiffness, point=(0.0, 0.0, 0.0), anchor=(0.0, 0.0, 0.0)):
    """Effect builder: zero-rest-length springs from each body's ``point`` to ``anchor``."""
    def make(bodies):
        return Springs(bodies, [SpringSpec(body=i, point=np.asarray(point, float),
                                           stiffness=stiffness, anchor=np.asarray(anchor, float))
                                for i in range(bodies.count)])
    return make


def pushed(force, point, max_force=1e4, max_torque=1e4, expires=np.inf):
    """Make an inputs builder: world-axes ``force`` at body point ``point`` until ``expires``."""
    def make(bodies):
        wrenches = AppliedWrenches(bodies, max_force, max_torque)
        wrenches.hold(0, 'push', 'world_point', force, point=point, expires=expires)
        return wrenches
    return make


def point_potential(world_, force, point):
    """``-F . p`` of a constant world force at a body point, J: makes the energy conserved."""
    position = world_.snapshot().point_world(np.array([0]), np.asarray(point)[None])[0]
    return -float(np.asarray(force) @ position)


@dataclass(frozen=True)
class HardCase:
    """One hard case: how to build it, its step, and its exact energy history."""

    key: str
    title: str
    dt: float            # s
    duration: float      # s, the test's run
    long_duration: float  # s, the benchmark's run
    build: object        # (integrator, auto_substep) -> World
    torque_free: bool = True
    exact_energy: object = None  # (time, E0) -> J; None: E0 for ever
    extra_energy: object = None  # world -> J added to world.energy() (a held force's potential)

    def energy(self, world_):
        """Return the energy this case conserves (or whose decay it knows), J."""
        extra = self.extra_energy(world_) if self.extra_energy else 0.0
        return world_.energy() + extra

    def exact(self, time_, energy0):
        """Return the exact energy at ``time_``, J."""
        return self.exact_energy(time_, energy0) if self.exact_energy else energy0


def fast_spin_case(omega_dt):
    """Return a body spun at 30 rad/s with a force at a point, stepped at ``|omega| dt``."""
    force, point = np.array([0.0, 0.0, -20.0]), np.array([0.1, 0.05, 0.0])
    return HardCase(
        f'fast_spin_{omega_dt:g}', f'fast spin, |omega| dt = {omega_dt:g}, offset force',
        omega_dt / 30.0, 1.0, 10.0, lambda name, auto: world(
            [1.0, 2.0, 3.0], np.array([3.0, -20.0, 22.0]) * 30.0 / np.sqrt(893.0),
            (), name, auto, orientation=TILTED, inputs=pushed(force, point)),
        torque_free=False, extra_energy=lambda w: point_potential(w, force, point))


def scaled_case(key, mass, size, limit):
    """Spinning body on an off-centre spring under a push, at ``mass`` kg and ``size`` m.

    Every rate is the same as the 1 kg, 1 m body's: only units change, so the nondimensional
    motion must be the same.
    """
    force, point = np.array([0.5, 0.0, -2.0]) * mass * size, np.array([0.2, 0.1, 0.0]) * size
    return HardCase(
        key, f'{mass:g} kg body of size {size:g} m, spring + push, |omega| dt = 0.5',
        0.05, 2.0, 20.0, lambda name, auto: world(
            [1.0, 2.0, 3.0], [4.0, -6.0, 7.0],
            [spring(100.0 * mass, point=np.array([0.0, 0.3, 0.1]) * size)],
            name, auto, mass=mass, scale=size, position=np.array([1.0, 0.0, 0.0]) * size,
            orientation=TILTED, inputs=pushed(force, point, limit, limit * size)),
        torque_free=False, extra_energy=lambda w: point_potential(w, force, point))


def impulse_case():
    """Return a body at rest kicked by a body-axes torque about z for exactly one step.

    The torque ``tau = 2 pi I3 / dt^2`` turns it by ``tau dt^2 / 2 I3 = pi`` within that step.
    """
    dt, moment = 0.01, 3.0
    torque = 2.0 * np.pi * moment / dt ** 2
    work = torque * np.pi   # J: the energy from the end of the kick on

    def make(bodies):
        wrenches = AppliedWrenches(bodies, max_torque=2.0 * torque)
        wrenches.hold(0, 'kick', 'body', np.zeros(3), (0.0, 0.0, torque), expires=dt)
        return wrenches
    return HardCase('impulse', 'impulsive torque: a turn of pi in one step', dt, 0.5, 10.0,
                    lambda name, auto: world([1.0, 2.0, moment], np.zeros(3), (), name,
                                             auto, orientation=TILTED, inputs=make),
                    torque_free=False, exact_energy=lambda t, e0: e0 if t < dt / 2 else work)


def far_mesh_case(offset=1e4):
    """Return a unit box whose frame origin is ``offset`` sizes from it.

    Its mass properties come from ``mesh_exact``; it spins torque-free, so its centre of mass
    stays put.
    """
    import trimesh
    from rigid_sim.core.inertia import mesh_exact
    box = trimesh.creation.box((1.0, 2.0, 3.0))
    box.apply_translation(np.array([1.0, 0.7, -0.3]) * offset)
    properties = mesh_exact(box, mass=6.0)
    moments = np.diag(properties.inertia) / 6.0
    return HardCase('far_mesh', f'mesh {offset:g} sizes from its frame origin', 0.01, 2.0, 20.0,
                    lambda name, auto: world(moments, [0.3, 2.0, 0.2], (), name, auto,
                                             mass=6.0, com=properties.center_of_mass))


def long_run_case(count=1, duration=10.0, long_duration=1e4):
    """``count`` spinning bodies, each on an off-centre spring, under gravity, dt = 0.01 s.

    The bodies are independent; their spins are spread over a factor 3 and their axes over
    directions, so one run samples ``count`` initial conditions.
    """
    spins = np.array([0.3, -0.5, 0.8]) * np.linspace(1.0, 3.0, count)[:, None]
    spins = spins + np.linspace(-0.5, 0.5, count)[:, None] * np.array([1.0, 0.5, -0.3])
    return HardCase(
        'long_run', f'long run: {count} spinning bodies on off-centre springs, gravity', 0.01,
        duration, long_duration, lambda name, auto: world(
            np.tile([1.0, 2.0, 3.0], (count, 1)), spins,
            [spring(10.0, point=(0.2, 0.0, 0.1)), lambda b: Gravity(b, (0.0, 0.0, -9.81))],
            name, auto, position=(0.3, 0.0, -1.0), orientation=TILTED), torque_free=False)


STIFF_SPRING = HardCase(
    'stiff_spring', 'stiff spring, k/m = 1e6, dt = 1e-3 (w dt = 1)', 1e-3, 0.1, 10.0,
    lambda name, auto: world([1.0, 2.0, 3.0], np.zeros(3), [spring(1e6)], name, auto,
                             position=(1e-3, 0.0, 0.0)), torque_free=False)
CASES = (
    HardCase('tumbling', 'intermediate axis, I = (1, 2, 3), omega0 = (0.01, 5, 0.01)', 0.05,
             100.0, 100.0,
             lambda name, auto: world([1.0, 2.0, 3.0], [0.01, 5.0, 0.01], (), name, auto)),
    HardCase('thin_rod', 'thin rod, I = (1e-4, 1, 1.0001), omega0 = (100, 1, 0)', 0.01, 10.0,
             10.0, lambda name, auto: world([1e-4, 1.0, 1.0001], [100.0, 1.0, 0.0], (), name,
                                            auto)),
    *(fast_spin_case(omega_dt) for omega_dt in (0.5, 1.0, 2.0, 3.0)),
    STIFF_SPRING,
    HardCase('damped', 'tumbling under momentum damping 0.5 1/s', 0.05, 4.0, 20.0,
             lambda name, auto: world(
                 [1.0, 2.0, 3.0], [0.01, 5.0, 0.01],
                 [lambda b: Damping(b, DAMPING_RATE, DAMPING_RATE)], name, auto,
                 velocity=(1.0, 0.0, 0.0)),
             torque_free=False,
             exact_energy=lambda t, e0: e0 * np.exp(-2.0 * DAMPING_RATE * t)),
    long_run_case(),
    impulse_case(),
    far_mesh_case(),
    scaled_case('tiny', 1e-6, 1e-3, 1e-3),
    scaled_case('unit', 1.0, 1.0, 1e4),
    scaled_case('huge', 1e6, 1e2, 1e12),
)
CASES_BY_KEY = {case.key: case for case in CASES}


@dataclass
class Outcome:
    """What one run of a case did; errors are the largest over every step."""

    finite: bool            # world.y never held a non-finite value
    energy_error: float     # |E - E_exact| / |E_exact|
    energy_sign: float      # sign of E - E_exact at the end: +1 gained, -1 lost
    momentum_error: float   # ||L| - |L0|| / |L0| per body (NaN when torqued)
    unit_error: float       # ||q| - 1|
    substeps: int           # the most substeps one step took
    rejected: int           # attempts rejected for a non-finite value
    failed: int             # steps given up
    cpu_time: float         # s

    def verdict(self):
        """One word for the table: holds, gains, loses, drifts (|L| or |q|) or diverges."""
        if not self.finite or self.failed or self.energy_error > 1e3:
            return 'diverges'
        if self.energy_error > ENERGY_RTOL:
            return 'gains' if self.energy_sign > 0 else 'loses'
        if self.momentum_error > NORM_RTOL or self.unit_error > NORM_RTOL:
            return 'drifts'
        return 'holds'


def run(case, integrator=DEFAULT_INTEGRATOR, auto_substep=True, duration=None):
    """Run ``case`` for ``duration`` (default its test duration); (Outcome, world)."""
    world_ = case.build(integrator, auto_substep)
    steps = int(round((duration or case.duration) / case.dt))
    momentum0 = np.linalg.norm(world_.y[:, ANGULAR_MOMENTUM], axis=1)
    energy0 = case.energy(world_)
    errors, substeps, finite = np.zeros(3), 1, True
    start = time.process_time()
    with np.errstate(all='ignore'):
        for _ in range(steps):
            world_.step(case.dt)
            substeps = max(substeps, world_.diagnostics.substeps)
            errors = np.maximum(errors, _errors(case, world_, energy0, momentum0))
            finite = finite and bool(np.isfinite(world_.y).all())
    cpu = time.process_time() - start
    sign = np.sign(case.energy(world_) - case.exact(world_.time, energy0))
    d = world_.diagnostics
    return Outcome(finite, *errors[:1], sign, *errors[1:], substeps, d.rejected_steps,
                   d.failed_steps, cpu), world_


def _errors(case, world_, energy0, momentum0):
    """Energy, |L| and |q| errors now: (3,) float, inf for a non-finite value."""
    exact = case.exact(world_.time, energy0)
    energy = abs(case.energy(world_) - exact) / max(abs(exact), np.finfo(float).tiny)
    momentum = np.nan   # not conserved under torque
    if case.torque_free:
        now = np.linalg.norm(world_.y[:, ANGULAR_MOMENTUM], axis=1)
        momentum = np.nan_to_num(np.max(np.abs(now - momentum0) / momentum0), nan=np.inf)
    unit = np.max(np.abs(np.linalg.norm(world_.y[:, ORIENTATION], axis=1) - 1.0))
    return np.array([np.nan_to_num(energy, nan=np.inf), momentum,
                     np.nan_to_num(unit, nan=np.inf)])


def outcome_row(case, outcomes):
    """Markdown cells: the case, then each run's verdict with its energy error."""
    cells = [f'{o.verdict()} ({bench.scientific(o.energy_error, 1)}'
             + (f', {o.substeps} substeps)' if o.substeps > 1 else ')') for o in outcomes]
    return [case.title] + cells


def add_arguments(parser):
    parser.add_argument('--cases', nargs='+', choices=sorted(CASES_BY_KEY),
                        default=sorted(CASES_BY_KEY), help='hard cases to run')
    parser.add_argument('--long', action='store_true',
                        help='run the default integrator for each case\'s long duration '
                             '(1e6 steps for long_run) instead of the test duration')
    parser.add_argument('--out', type=Path, help='Markdown file whose section is (re)written')


def main(args):
    """Run every case through every integrator bare and the default with safeguards."""
    names = sorted(REGISTRY)
    header = ['case', f'{DEFAULT_INTEGRATOR} + safeguards'] + [f'{n} bare' for n in names]
    rows, seconds = [], 0.0
    for key in args.cases:
        case = CASES_BY_KEY[key]
        guarded, _ = run(case, duration=case.long_duration if args.long else None)
        bare = [run(case, name, auto_substep=False)[0] for name in names]
        seconds += guarded.cpu_time + sum(o.cpu_time for o in bare)
        rows.append(outcome_row(case, [guarded] + bare))
        print(' | '.join(rows[-1]), flush=True)
    body = '\n'.join([f'Command: `{bench.command_line()}`', ''] + bench.machine_description()
                     + [f'- CPU time of the whole run: {seconds:.0f} s', '',
                        bench.markdown_table(header, rows)])
    if args.out:
        bench.write_section(args.out, SECTION, body)
