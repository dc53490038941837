# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Error estimates against closed-form motion, and error control that honours tolerance.

The true error of one step is the scaled difference (rigid_sim.core.error_estimate) between
the integrator's result and the closed-form motion from the same state: a harmonic oscillator
(a body on a spring at its centre of mass) and a torque-free symmetric top; for a torque-free
asymmetric body, the motion DOP853 integrates from Euler's equations (rigid_sim.bench.oracles).
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from physics_cases import FIXED_STEP
from rigid_sim.bench import cases as accuracy_cases
from rigid_sim.bench import estimate_cases, oracles, stability
from rigid_sim.bench import estimates as estimates_bench
from rigid_sim.core import step_control
from rigid_sim.core.effects.springs import Springs, SpringSpec
from rigid_sim.core.error_estimate import true_errors
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.rotation import angle_between
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World

MASS, OMEGA = 2.0, 5.0            # kg, rad/s of the oscillator
X0, V0 = np.array([0.4, -0.1, 0.2]), np.array([0.3, 0.5, -0.2])   # m, m/s
TOP = np.diag([0.5, 0.5, 0.2])    # kg m^2: symmetric about body z
TOP_TURN = Rotation.from_rotvec([0.3, -0.2, 0.5])
TOP_SPIN = np.array([1.0, -2.0, 6.0])   # rad/s, body axes


def oscillator(name, error_control=False, tolerance=1e-6):
    """Build a body on a spring of natural frequency OMEGA from its centre to the origin."""
    bodies = RigidBodies(('body',), np.array([MASS]), np.diag([0.3, 0.4, 0.5])[None],
                         np.zeros((1, 3)))
    y = initial_state(bodies, X0[None], np.array([[0.0, 0.0, 0.0, 1.0]]), V0[None],
                      np.zeros((1, 3)))
    spring = SpringSpec(body=0, point=np.zeros(3), stiffness=MASS * OMEGA ** 2, damping=0.0,
                        anchor=np.zeros(3))
    return World(bodies, y, [Springs(bodies, [spring])], name, tolerance,
                 auto_substep=error_control, error_control=error_control)


def oscillator_exact(y, dt):
    """Return the oscillator's state ``dt`` after ``y``: x = x0 cos wt + v0/w sin wt."""
    x, v = y[0, 0:3], y[0, 7:10] / MASS
    exact = y.copy()
    exact[0, 0:3] = x * np.cos(OMEGA * dt) + v / OMEGA * np.sin(OMEGA * dt)
    exact[0, 7:10] = MASS * (v * np.cos(OMEGA * dt) - x * OMEGA * np.sin(OMEGA * dt))
    return exact


def top(name, error_control=False, tolerance=1e-6):
    """Build a torque-free symmetric top spinning mostly about its symmetry axis."""
    bodies = RigidBodies(('top',), np.array([1.0]), TOP[None], np.zeros((1, 3)))
    y = initial_state(bodies, np.zeros((1, 3)), TOP_TURN.as_quat()[None], np.zeros((1, 3)),
                      TOP_TURN.apply(TOP_SPIN)[None])
    return World(bodies, y, [], name, tolerance, auto_substep=error_control,
                 error_control=error_control)


def top_exact(y, dt):
    """Return the top's state ``dt`` after ``y``: R(t) = Rot(L t / A) R0 Rot(e3 mu t).

    ``A`` is the transverse moment, ``mu = (A - C) omega_3 / A`` the body-frame precession;
    world ``L`` is constant.
    """
    transverse, axial = TOP[0, 0], TOP[2, 2]
    turn, big_l = Rotation.from_quat(y[0, 3:7]), y[0, 10:13]
    omega_3 = turn.inv().apply(big_l)[2] / axial
    precession = (transverse - axial) * omega_3 / transverse
    exact = y.copy()
    exact[0, 3:7] = (Rotation.from_rotvec(big_l * dt / transverse) * turn
                     * Rotation.from_rotvec([0.0, 0.0, precession * dt])).as_quat()
    return exact


CASES = {'spring': (oscillator, oscillator_exact), 'top': (top, top_exact)}


def one_step(case, name, dt, **world_options):
    """Return the estimate, true error and substeps of five steps of ``dt`` along the case."""
    build, exact = CASES[case]
    world = build(name, **world_options)
    pairs = []
    for _ in range(5):
        start = world.y.copy()
        assert world.step(dt)
        true = true_errors(world.bodies, exact(start, dt), world.y, dt)[0]
        pairs.append((world.integrator.error[0], true, world.diagnostics.substeps))
    return pairs


def test_the_closed_forms_are_the_motion():
    """The closed forms agree with each other's physics: energy and |L| are kept.

    The oscillator's energy and the top's |L| and rotational energy are the same after any
    time, and the top's body-frame angular velocity keeps its axial component.
    """
    y = oscillator('rk4').y
    later = oscillator_exact(y, 0.37)
    energy = [0.5 * s[0, 7:10] @ s[0, 7:10] / MASS
              + 0.5 * MASS * OMEGA ** 2 * s[0, 0:3] @ s[0, 0:3] for s in (y, later)]
    assert energy[1] == pytest.approx(energy[0], rel=1e-12)
    y = top('rk4').y
    later = top_exact(y, 0.37)
    spins = [np.linalg.solve(TOP, Rotation.from_quat(s[0, 3:7]).inv().apply(s[0, 10:13]))
             for s in (y, later)]
    assert spins[1][2] == pytest.approx(spins[0][2], rel=1e-12)
    assert 0.5 * spins[1] @ TOP @ spins[1] == pytest.approx(0.5 * spins[0] @ TOP @ spins[0],
                                                            rel=1e-12)
    assert not np.allclose(spins[1], spins[0])


@pytest.mark.parametrize('case', sorted(CASES))
@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_estimate_is_within_a_factor_ten_of_the_true_error(case, name):
    """Every method's estimate of one step is within 10x of the closed form's error.

    At two steps a factor 4 apart, so that the estimate follows the error's order. The
    exact flow moves the torque-free top exactly: its error is round-off, and so is its
    estimate (exact_split's terms are 0, exact_split4's Richardson difference reads the
    round-off). Error control is off: one step as it comes.
    """
    # dopri5 chooses its own steps: longer intervals and a loose tolerance give it errors
    # above round-off.
    for dt in (0.1, 0.04) if REGISTRY[name].adaptive else (0.02, 0.005):
        for estimate, true, _ in one_step(case, name, dt, tolerance=1e-3):
            if case == 'top' and name.startswith('exact_split'):
                assert estimate < 1e-13 and true < 1e-13, (dt, estimate, true)
                continue
            assert true > 1e-13   # above round-off: the comparison means something
            assert 0.1 * true <= estimate <= 10.0 * true, (dt, estimate, true)


# A torque-free asymmetric body whose body axes are principal, spinning about no axis: every
# one of the DLM drift's five rotations turns it.
ASYMMETRIC = np.diag([0.8, 1.3, 2.0])   # kg m^2
ASYMMETRIC_SPIN = np.array([1.2, -2.0, 0.9])   # rad/s, body axes; 2 rad/s the fastest


def asymmetric(name):
    """Build the torque-free asymmetric body, no substeps and no error control."""
    bodies = RigidBodies(('body',), np.array([1.0]), ASYMMETRIC[None], np.zeros((1, 3)))
    y = initial_state(bodies, np.zeros((1, 3)), TOP_TURN.as_quat()[None], np.zeros((1, 3)),
                      TOP_TURN.apply(ASYMMETRIC_SPIN)[None])
    return World(bodies, y, [], name, auto_substep=False, error_control=False)


def asymmetric_reference(y, dt):
    """Return the asymmetric body's state ``dt`` after ``y`` by DOP853 on Euler's equations."""
    q = y[0, 3:7]
    spin = np.linalg.solve(ASYMMETRIC, oracles.world_from_body(q).T @ y[0, 10:13])
    _, _, q_later, spin_later = oracles.reference_motion(
        1.0, ASYMMETRIC, (np.zeros(3), np.zeros(3), q, spin), [dt])
    later = y.copy()
    later[0, 3:7] = q_later[-1]
    later[0, 10:13] = oracles.world_from_body(q_later[-1]) @ ASYMMETRIC @ spin_later[-1]
    return later


def drift_ratios(dt, steps=4):
    """Return dlm's estimate / true error of ``steps`` steps of ``dt`` of the asymmetric body."""
    world = asymmetric('dlm')
    ratios = []
    for _ in range(steps):
        start = world.y.copy()
        assert world.step(dt)
        true = true_errors(world.bodies, asymmetric_reference(start, dt), world.y, dt)[0]
        assert true > 1e-11   # far above the reference's own error
        ratios.append(world.integrator.error[0] / true)
    return np.array(ratios)


def test_dlm_estimate_follows_the_drift_error_of_an_asymmetric_body():
    """The DLM drift's estimate is within 10x of its true error, and tends to it as h -> 0.

    A torque-free body: the drift is the whole step. At 0.2 s the fastest axis turns by
    0.4 rad a step, where the estimate compares with the exact flow; at 0.03 and 0.0075 s
    (0.06 and 0.015 rad) it is the error's leading term, whose ratio to the true error is
    ``1 + O(h)``: within the angle turned of 1.
    """
    fastest = np.abs(ASYMMETRIC_SPIN).max()
    for dt in (0.2, 0.03, 0.0075):
        ratios = drift_ratios(dt)
        assert np.all(ratios >= 0.1) and np.all(ratios <= 10.0), (dt, ratios)
        if dt < 0.1:
            assert np.all(np.abs(ratios - 1.0) <= fastest * dt), (dt, ratios)


TOLERANCE = 1e-4
# With error control the true error of a step stays within this multiple of the tolerance:
# control keeps every accepted estimate below the tolerance, and the estimates that are
# not upper bounds fall short of the true error by at most the factor the test above allows.
WITHIN = 10.0


@pytest.mark.parametrize('case', sorted(CASES))
@pytest.mark.parametrize('name', FIXED_STEP)
def test_error_control_brings_every_method_within_tolerance(case, name):
    """A step of 0.2 s (0.05 s: first order) errs far beyond TOLERANCE; control splits it.

    The bare step's true error is above 5 TOLERANCE (where the method is not exact); with
    error control on the true error of every step is within WITHIN times TOLERANCE, and
    the estimate never above it.
    """
    dt = 0.05 if REGISTRY[name].order == 1 else 0.2
    bare = max(true for _, true, _ in one_step(case, name, dt))
    controlled = one_step(case, name, dt, error_control=True, tolerance=TOLERANCE)
    if case == 'top' and name.startswith('exact_split'):
        assert bare < 1e-13 and all(substeps == 1 for _, _, substeps in controlled)
        return
    assert bare > 5.0 * TOLERANCE
    for estimate, true, substeps in controlled:
        assert estimate <= TOLERANCE
        assert true <= WITHIN * TOLERANCE, (true, substeps)
    assert max(substeps for _, _, substeps in controlled) > 1


def test_error_control_gives_substeps_back():
    """Once the motion calms down, the count falls again (with the hold margin).

    A top spun fast about its axis needs substeps at rk4; spun down to a tenth (a state set
    from outside), the same tolerance needs fewer.
    """
    world = top('rk4', error_control=True, tolerance=1e-8)
    for _ in range(5):
        world.step(0.05)
    fast = world.diagnostics.substeps
    assert fast > 1
    slow = world.y.copy()
    slow[0, 10:13] *= 0.1
    world.y = slow
    for _ in range(5):
        world.step(0.05)
    assert world.diagnostics.substeps < fast
    assert world.diagnostics.error_estimate <= 1e-8


def test_error_control_work_is_capped(monkeypatch):
    """A tolerance out of reach splits a step into at most ERROR_WORK / N substeps.

    The step is kept (its estimate above the tolerance) and the reason says it was capped.
    """
    monkeypatch.setattr(step_control, 'ERROR_WORK', 20)
    world = oscillator('rk4', error_control=True, tolerance=1e-12)
    assert world.step(0.2)
    assert world.diagnostics.substeps == 20
    assert world.diagnostics.error_estimate > 1e-12
    assert 'capped at 20 substeps' in world.diagnostics.reason


# Cases the estimates benchmark's sets do not hold, judged by an oracle with forces of its
# own (estimate_cases): each method's estimate of a bare step against the true local error.
ORACLE_STEPS = 4
FLOOR = 1e-13   # scaled error below which estimate and truth are both round-off
# Local errors beyond this are outside the regime an estimate is for: error control splits
# such a step long before, so an estimate above it need not be close, only not below the
# truth. A diverging bare method reaches them (euler on the rod: estimate 0.32, truth 6.6e-4).
ASYMPTOTIC = 1e-3
# An estimate measured beyond 10x above the truth, with the factor it stays within
# (docs/accuracy.md, "Error estimates"): rk4's and rk4_world's rate-scaled difference under
# the damped spring (10.4 to 11.7x; rk4_world 10.8x); dopri5's on the rod's first step (34x):
# its first internal steps see the body-axes L's coupling through I_min = 1e-4 (z = 1e4 to
# 4e3 from the stages), where the leading term says nothing and the difference is kept whole.
OUTSIDE_BAND = {('rk4', 'pushed_damped'): 15.0, ('rk4_world', 'pushed_damped'): 15.0,
                ('dopri5', 'rod'): 50.0}
# The round-off a method declares its estimate omits (``estimate_omits``: the exact flow's)
# may show on either side of the band: the true error beyond the estimate (3.6e-11 over 100
# steps of the rod, the same against a 40-digit Taylor solution), or, in exact_split4's
# Richardson difference, the estimate beyond the truth (6.1e-11 where the truth was
# 2.2e-11). Both stay below this.
OMITTED = 1e-10


def oracle_pairs(key, name):
    """Return (estimate, true error) of ORACLE_STEPS bare steps of the case ``key``.

    Adaptive methods take an interval of ten of the case's steps, where they choose their own.
    """
    case = estimate_cases.CASES[key]
    world = case.world(name)
    dt = case.dt * (10 if REGISTRY[name].adaptive else 1)
    pairs = []
    for _ in range(ORACLE_STEPS):
        start, time = world.y[0].copy(), world.time
        assert world.step(dt)
        pairs.append((world.integrator.error[0], case.true_error(start, world.y[0], dt, time)))
    return pairs


@pytest.mark.parametrize('key', sorted(estimate_cases.CASES))
@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_estimate_tracks_the_oracle(key, name):
    """Every estimate is within [0.1, 10] of the oracle's local error.

    One measured beyond 10x keeps its factor (OUTSIDE_BAND); where an estimate leaves the
    band by what it declares it omits, both stay below the level measured (OMITTED). Where
    the truth is round-off (below FLOOR) the estimate must be too.
    """
    above = OUTSIDE_BAND.get((name, key), 10.0)
    for estimate, true in oracle_pairs(key, name):
        if true > ASYMPTOTIC:
            continue
        outside = estimate < 0.1 * true or estimate > above * true
        if REGISTRY[name].estimate_omits and outside:
            assert max(estimate, true) <= OMITTED, (estimate, true)
            continue
        if true < FLOOR:
            assert estimate < 10.0 * FLOOR, (estimate, true)
            continue
        assert estimate >= 0.1 * true, (estimate, true)
        assert estimate > ASYMPTOTIC or estimate <= above * true, (estimate, true)


def test_error_control_does_not_lock_the_count_to_the_orbit():
    """On the long run's body the count settles, and stays, once the estimate is met.

    exact_split at dt 0.01 with its bounds and error control at 1e-6: the bounds ask for 2
    substeps, whose estimate (2.5e-7) hovers at a quarter of the tolerance. A count that
    follows an estimate near the aim flips with the orbit (each flip shifts the energy a
    symplectic method keeps); held, it changes once, at the start.
    """
    world = stability.long_run_case().build('exact_split', True)
    counts = []
    for _ in range(8000):
        assert world.step(0.01)
        counts.append(world.diagnostics.substeps)
    assert max(world.diagnostics.error_estimate, 0.0) <= 1e-6
    switches = int(np.count_nonzero(np.diff(counts)))
    assert switches <= 2, (switches, np.unique(counts))


# dopri5 on the thin rod, error control at 1e-6: a step is ten of the case's steps, the
# interval the oracle tests above give an adaptive method; 200 of them turn the rod 20 rad.
ADAPTIVE_TOLERANCE = 1e-6
ADAPTIVE_STEPS = 200
ORACLE_EVERY = 5   # steps between the oracle's checks (each a DOP853 run at rtol 1e-13)


def flagged(diagnostics):
    """Whether the last step says it missed its tolerance: given up, or error control capped."""
    why = diagnostics.why
    return isinstance(why, step_control.ErrorReason) and why.capped


def test_dopri5_meets_its_tolerance_on_the_rod_or_says_so():
    """Every dopri5 step keeps its reported estimate within tolerance, or is flagged.

    The estimate of a step sums those of its internal steps; a step whose sum exceeds
    ``tolerance`` must be given up or carry a capped reason. On the rod (error control at
    1e-6, steps of 0.01 s) the oracle's local error is above round-off and within [0.1, 10]
    of the estimate, or of the factor the rod's spin takes it beyond (OUTSIDE_BAND).
    """
    case = estimate_cases.CASES['rod']
    dt = 10 * case.dt
    world = case.world('dopri5', error_control=True, tolerance=ADAPTIVE_TOLERANCE)
    unflagged_over, taken, checked = 0, 0, []
    for k in range(ADAPTIVE_STEPS):
        start, time = world.y[0].copy(), world.time
        if not world.step(dt):
            continue   # given up, the state kept: flagged as a failed step
        taken += 1
        estimate = world.integrator.error[0]
        assert estimate == world.diagnostics.error_estimate
        if estimate > ADAPTIVE_TOLERANCE and not flagged(world.diagnostics):
            unflagged_over += 1
        if k % ORACLE_EVERY == 0:
            checked.append((estimate, case.true_error(start, world.y[0], dt, time)))
    assert taken == ADAPTIVE_STEPS - world.diagnostics.failed_steps
    assert taken >= ADAPTIVE_STEPS // 2   # not met by giving every step up
    assert unflagged_over == 0, (unflagged_over, taken)
    above = OUTSIDE_BAND['dopri5', 'rod']
    for estimate, true in checked:
        assert true > FLOOR, (estimate, true)
        assert 0.1 * true <= estimate <= above * true, (estimate, true)


def test_dlm4_under_error_control_is_no_worse_than_bare_through_the_flips():
    """dlm4 with error control ends nearer the oracle than without, never farther.

    The tumbling body (I = 1, 2, 3, spun near the intermediate axis) flips every few seconds
    over 20 s; the oracle is DOP853 on Euler's equations at 1e-13. dlm4's estimate used to
    bound its error 49 to 280 times over, so control split the steps inside each flip and
    gave them back between: every change of the count shifts the energy a symplectic method
    keeps, and the controlled run ended twice as far off as the bare one. With the estimate
    the true error, a tolerance the bare steps meet leaves them as they are, and a tighter
    one brings the end nearer.
    """
    case = accuracy_cases.CASES_BY_KEY['tumbling']
    dt, reference = 0.02, case.oracle().orientation

    def end_error(tolerance):
        world = case.build('dlm4')
        if tolerance is not None:
            world = estimates_bench.controlled(world, tolerance)
        for _ in range(round(case.duration / dt)):
            assert world.step(dt)
        return angle_between(reference[None], world.y[0, 3:7][None])[0]

    bare = end_error(None)
    assert 1e-6 < bare < 1e-3   # far above the oracle's error, and still an answer
    assert end_error(1e-6) <= bare
    assert end_error(1e-8) < 0.75 * bare
