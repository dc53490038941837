# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The accuracy benchmark runs end to end and its oracles are right.

The tiny ``--quick`` configuration must list every registered integrator on every case, so an
integrator added to the registry without appearing in the benchmark fails here.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.bench import cli
from rigid_sim.bench.cases import CASES_BY_KEY, IDENTITY, MOMENTS
from rigid_sim.core.rotation import angle_between
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.integrators.free_rotation import torque_free_flow

CASE_HEADING = '### '


def table_methods(markdown):
    """Return the method names in the first column of each case's table, keyed by case key."""
    methods, case = {}, None
    for line in markdown.splitlines():
        if line.startswith(CASE_HEADING):
            key = line[len(CASE_HEADING):].split(':')[0]
            case = key if key in CASES_BY_KEY else None
        elif case and line.startswith('| ') and not line.startswith(('| method', '| ---')):
            methods.setdefault(case, set()).add(line.split('|')[1].strip())
    return methods


def test_quick_benchmark_lists_every_integrator(tmp_path, capsys):
    """Every registered integrator has a row on every case.

    The report, its Markdown section and its plot are written; and DLM conserves |L| of a
    torque-free body to round-off (its free rotations about principal axes each keep L's length
    exactly).
    """
    out = tmp_path / 'accuracy.md'
    out.write_text('# Hand-written title\n')
    parser = cli.build_parser()
    args = parser.parse_args(['accuracy', '--quick', '--no-progress', '--out', str(out)])
    results = args.run(args)
    printed = capsys.readouterr().out
    listed = table_methods(printed)
    assert set(listed) == set(CASES_BY_KEY)
    for case, methods in listed.items():
        assert methods == set(REGISTRY), case
    assert (tmp_path / 'accuracy_work_precision.png').read_bytes()[:4] == b'\x89PNG'
    written = out.read_text()
    assert written.startswith('# Hand-written title')
    assert table_methods(written) == listed
    torque_free = [r for r in results if r.method == 'dlm' and CASES_BY_KEY[r.case].torque_free]
    assert torque_free
    # Round-off grows with the number of sub-rotations (~1e3 here): far below any O(dt^2).
    assert max(r.momentum_drift for r in torque_free) < 1e-11


def test_tumbling_oracle_matches_closed_form_flow():
    """The DOP853 oracle of the tumbling case agrees with the closed-form torque-free flow.

    The flow uses Jacobi elliptic functions; the two independent solutions of Euler's equations
    agree to 1e-9 in orientation and body angular momentum after 20 s.
    """
    case = CASES_BY_KEY['tumbling']
    reference = case.oracle()
    body_l = MOMENTS * np.asarray(case.omega0)
    flow_l, flow_q = torque_free_flow(MOMENTS[None], body_l[None], IDENTITY[None],
                                      case.duration)
    assert angle_between(flow_q, reference.orientation[None])[0] < 1e-9
    world_from_body = Rotation.from_quat(reference.orientation)
    reference_l = MOMENTS * world_from_body.inv().apply(reference.angular_velocity)
    assert np.linalg.norm(flow_l[0] - reference_l) < 1e-9 * np.linalg.norm(body_l)


def test_a_run_the_world_gave_up_on_is_scored_diverged_in_every_column():
    """RK4 at 4 s steps on the tumbling body fails even in 16 pieces, so it scores diverged.

    The World keeps an earlier state: its energy and |L| are the starting ones, which must not
    read as exact.
    """
    from rigid_sim.bench.accuracy import measure_rigid
    result = measure_rigid(CASES_BY_KEY['tumbling'], 4.0, 1, 60.0, 'rk4')
    errors = (result.orientation_error, result.omega_error, result.position_error,
              result.energy_drift, result.momentum_drift)
    assert all(np.isinf(error) for error in errors)


def test_an_adaptive_run_is_not_cut_short_by_the_per_call_cap():
    """dopri5 takes the whole tumbling interval in one call, past the node's per-call cap.

    Over 20 s the body turns ~100 rad about a near-unstable axis, far more internal steps than
    the node allows one tick: the benchmark lifts the cap for its own run, so the run is scored
    (finite errors, none of them a give-up) and a tighter tolerance lands closer to the oracle.
    """
    from rigid_sim.bench.accuracy import measure_rigid
    from rigid_sim.core.integrators.adaptive import MAX_INTERNAL_STEPS
    case = CASES_BY_KEY['tumbling']
    coarse, fine = (measure_rigid(case, tolerance, 1, 60.0, 'dopri5')
                    for tolerance in (1e-3, 1e-5))
    # An internal step costs about seven evaluations (more after a rejected try): twice what
    # the cap allows means the run went well past it.
    assert coarse.evaluations > 2 * 7 * MAX_INTERNAL_STEPS, coarse
    for result in (coarse, fine):
        assert np.isfinite([result.orientation_error, result.omega_error,
                            result.energy_drift, result.momentum_drift]).all(), result
    assert fine.orientation_error < coarse.orientation_error < 1.0, (coarse, fine)


def test_mujoco_runs_the_torqued_cases_as_specified():
    """The torqued cases in MuJoCo's RK4 converge to the same oracles as our methods.

    The spring is slide joints with stiffness and damping plus a ball joint; the offset
    force is a site actuator in world axes. At dt = 1e-3 a fourth-order method errs ~1e-11
    over these 10 s, and ten times the step gives ~1e4 times the error.
    """
    from rigid_sim.bench import mujoco_baseline
    for key, kind in (('spring', 'position'), ('offset_force', 'orientation')):
        case = CASES_BY_KEY[key]
        fine, coarse = (mujoco_baseline.measure(case, dt, 1, np.inf, 'RK4')
                        for dt in (1e-3, 1e-2))
        assert fine.error(kind) < 1e-9, (key, fine)
        assert 3e3 < coarse.error(kind) / fine.error(kind) < 3e4, (key, fine, coarse)
        assert fine.energy_drift < 1e-9, (key, fine)


def test_the_benchmark_help_needs_none_of_the_bench_extra():
    """``rigid_sim_bench --help`` after the README's run command, which installs no tqdm."""
    import subprocess
    import sys
    hide = ("import sys; sys.modules.update(tqdm=None, matplotlib=None, mujoco=None); "
            "from rigid_sim.bench import cli; cli.main(['--help'])")
    done = subprocess.run([sys.executable, '-c', hide], capture_output=True, text=True)
    assert done.returncode == 0 and 'throughput' in done.stdout, done.stderr
