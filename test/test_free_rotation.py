# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The exact torque-free flow against physics: Euler's equations, symmetric tops, invariants."""
import functools

import numpy as np
import pytest

from rigid_sim.bench import oracles
from rigid_sim.core.integrators.free_rotation import torque_free_flow

MOMENTS = np.array([1.0, 2.0, 3.0])
START = np.array([0.1, -0.2, 0.3, 0.9]) / np.linalg.norm([0.1, -0.2, 0.3, 0.9])
# Near the intermediate axis, and spinning about the minor and about the major axis.
OMEGAS = ((0.1, 5.0, 0.1), (5.0, 0.1, 0.1), (0.1, 0.1, 5.0))
DURATION = 20.0
STEPS = 1000
ANGLE_TOL = 1e-9        # rad, against a DOP853 reference at rtol = atol = 1e-12
MOMENTUM_TOL = 1e-9     # relative


def quat_mul(p, q):
    """Hamilton product of scalar-last quaternions (x, y, z, w), broadcasting."""
    pv, pw = p[..., :3], p[..., 3:]
    qv, qw = q[..., :3], q[..., 3:]
    return np.concatenate((pw * qv + qw * pv + np.cross(pv, qv),
                           pw * qw - np.sum(pv * qv, axis=-1, keepdims=True)), axis=-1)


def quat_angle(p, q):
    """Angle of the rotation p^-1 q, rad (sign of the quaternion ignored)."""
    relative = quat_mul(p * np.array([-1.0, -1.0, -1.0, 1.0]), q)
    return 2.0 * np.arctan2(np.linalg.norm(relative[..., :3], axis=-1), np.abs(relative[..., 3]))


def quat_rotate(q, v):
    """R(q) v for quaternion(s) q and vector(s) v."""
    pure = np.concatenate((v, np.zeros(v.shape[:-1] + (1,))), axis=-1)
    conj = q * np.array([-1.0, -1.0, -1.0, 1.0])
    return quat_mul(quat_mul(q, pure), conj)[..., :3]


def axis_angle(axis, angle):
    """Quaternion of a rotation by angle about a unit axis."""
    return np.append(np.sin(0.5 * angle) * np.asarray(axis), np.cos(0.5 * angle))


def euler_solution(omega0, duration, atol=1e-12, rtol=1e-12):
    """Return body m (3,) and orientation (4,) at ``duration`` from START, by DOP853."""
    start = (np.zeros(3), np.zeros(3), START, np.asarray(omega0, dtype=float))
    _, _, q, omega = oracles.reference_motion(1.0, np.diag(MOMENTS), start, [duration],
                                              rtol=rtol, atol=atol)
    return MOMENTS * omega[-1], q[-1]


@functools.lru_cache(maxsize=None)
def reference(omega0):
    """Body angular momentum and orientation at DURATION from a tight DOP853 solve."""
    return euler_solution(omega0, DURATION)


@pytest.mark.parametrize('omega0', OMEGAS)
def test_one_long_step_matches_euler_equations(omega0):
    """One call over 20 s reproduces the solution of Euler's equations (both regimes)."""
    m_ref, q_ref = reference(omega0)
    m, q = torque_free_flow(MOMENTS[None], (MOMENTS * omega0)[None], START[None], DURATION)
    assert quat_angle(q_ref, q[0]) <= ANGLE_TOL
    assert np.linalg.norm(m[0] - m_ref) <= MOMENTUM_TOL * np.linalg.norm(m_ref)


@pytest.mark.parametrize('omega0', OMEGAS)
def test_many_short_steps_match_euler_equations(omega0):
    """1000 calls of 0.02 s compose to the same motion: the flow is a one-parameter group."""
    m_ref, q_ref = reference(omega0)
    m, q = (MOMENTS * omega0)[None], START[None]
    for _ in range(STEPS):
        m, q = torque_free_flow(MOMENTS[None], m, q, DURATION / STEPS)
    assert quat_angle(q_ref, q[0]) <= ANGLE_TOL
    assert np.linalg.norm(m[0] - m_ref) <= MOMENTUM_TOL * np.linalg.norm(m_ref)


def test_one_batch_of_slow_and_fast_bodies_matches_each_solution():
    """One call advances fast and slow bodies, each on its own solution of Euler's equations.

    Some bodies' m passes several half periods within the step, others barely move.
    """
    scales = (1e-3, 0.3, 1.0, 4.0)
    omega0, dt = np.array(OMEGAS[0]), 3.0
    m, q = torque_free_flow(np.tile(MOMENTS, (len(scales), 1)),
                            np.array([MOMENTS * omega0 * s for s in scales]),
                            np.tile(START, (len(scales), 1)), dt)
    for i, scale in enumerate(scales):
        m_ref, q_ref = euler_solution(omega0 * scale, dt, atol=1e-15)
        assert quat_angle(q_ref, q[i]) <= ANGLE_TOL
        assert np.linalg.norm(m[i] - m_ref) <= MOMENTUM_TOL * np.linalg.norm(m_ref)


@pytest.mark.parametrize('order', [(0, 1, 2), (2, 0, 1), (1, 0, 2), (2, 1, 0)])
def test_axis_order_and_batching_do_not_matter(order):
    """Neither the order of the principal axes nor batching changes the physical motion.

    The axes are listed in another order, with the quaternion relabelled to the same physical
    body, and all cases advance in one batch.
    """
    order = list(order)
    # Relabelling axes by a permutation matrix S (v_new = S v); flip one axis if det S = -1.
    relabel = np.eye(3)[order]
    relabel[0] *= np.linalg.det(relabel)
    from scipy.spatial.transform import Rotation
    body_from_new = Rotation.from_matrix(relabel.T).as_quat()
    start = quat_mul(START, body_from_new)
    moments = np.tile(MOMENTS[order], (len(OMEGAS), 1))
    m0 = np.array([relabel @ (MOMENTS * np.array(w)) for w in OMEGAS])
    m, q = torque_free_flow(moments, m0, np.tile(start, (len(OMEGAS), 1)), DURATION)
    for i, omega0 in enumerate(OMEGAS):
        m_ref, q_ref = reference(omega0)
        assert np.linalg.norm(relabel.T @ m[i] - m_ref) <= MOMENTUM_TOL * np.linalg.norm(m_ref)
        assert quat_angle(q_ref, quat_mul(q[i], body_from_new * [-1, -1, -1, 1])) <= ANGLE_TOL


@pytest.mark.parametrize('moments, axis', [((1.0, 1.0, 3.0), 2), ((2.0, 2.0, 0.5), 2),
                                           ((3.0, 1.5, 1.5), 0)])
def test_symmetric_top_precesses_in_closed_form(moments, axis):
    """Symmetric top.

    omega along the symmetry axis is constant, omega_perp turns about it in the body at (I3 -
    I1)/I1 omega3, and the world symmetry axis precesses about the fixed L at |L|/I1 keeping its
    angle to L.
    """
    moments = np.array(moments)
    perp = [i for i in range(3) if i != axis]
    i_axis, i_perp = moments[axis], moments[perp[0]]
    omega0 = np.zeros(3)
    omega0[axis], omega0[perp[0]], omega0[perp[1]] = 2.0, 0.4, -0.3
    m0 = moments * omega0
    t = 7.3
    m, q = torque_free_flow(moments[None], m0[None], START[None], t)
    omega = m[0] / moments
    body_rate = (i_axis - i_perp) / i_perp * omega0[axis]
    # Right-handed about the symmetry axis in the order (perp0, perp1, axis) of a cyclic triple.
    handed = 1.0 if (axis, perp[0], perp[1]) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    c, s = np.cos(body_rate * t), handed * np.sin(body_rate * t)
    expected = np.zeros(3)
    expected[axis] = omega0[axis]
    expected[perp[0]] = c * omega0[perp[0]] - s * omega0[perp[1]]
    expected[perp[1]] = s * omega0[perp[0]] + c * omega0[perp[1]]
    assert np.allclose(omega, expected, rtol=0.0, atol=1e-12 * np.linalg.norm(omega0))
    l_world = quat_rotate(START, m0)
    l_norm = np.linalg.norm(m0)
    precession = axis_angle(l_world / l_norm, l_norm / i_perp * t)
    e = np.eye(3)[axis]
    expected_axis = quat_rotate(precession, quat_rotate(START, e))
    assert np.allclose(quat_rotate(q[0], e), expected_axis, rtol=0.0, atol=1e-12)


def test_sphere_turns_rigidly_about_l():
    """A spherical body keeps m and rotates about the fixed L at |L|/I."""
    m0 = np.array([0.3, -1.2, 0.7])
    t = 3.1
    m, q = torque_free_flow([[2.0, 2.0, 2.0]], m0[None], START[None], t)
    assert np.allclose(m[0], m0, rtol=0.0, atol=1e-15)
    turn = axis_angle(m0 / np.linalg.norm(m0), np.linalg.norm(m0) / 2.0 * t)
    assert quat_angle(quat_mul(START, turn), q[0]) <= 1e-13


def test_zero_momentum_leaves_the_body_alone():
    """Without angular momentum nothing turns."""
    m, q = torque_free_flow([[1.0, 2.0, 3.0], [2.0, 2.0, 2.0]], np.zeros((2, 3)),
                            np.tile(START, (2, 1)), 5.0)
    assert np.array_equal(m, np.zeros((2, 3)))
    assert np.allclose(q, START, rtol=0.0, atol=1e-16)


def test_intermediate_axis_equilibrium_spins_steadily():
    """With m exactly along the intermediate axis the body spins steadily at m2/I2."""
    m, q = torque_free_flow(MOMENTS[None], [[0.0, 4.0, 0.0]], START[None], 2.5)
    assert np.array_equal(m[0], [0.0, 4.0, 0.0])
    assert quat_angle(quat_mul(START, axis_angle([0.0, 1.0, 0.0], 2.0 * 2.5)), q[0]) <= 1e-13


def near_axis_solution(m0, duration):
    """Return body m and orientation after ``duration`` from ``m0``, START, by DOP853.

    A purely relative error control follows components of 1e-17 as closely as 10.
    """
    return euler_solution(np.asarray(m0) / MOMENTS, duration, atol=1e-40, rtol=1e-13)


@pytest.mark.parametrize('offset', [1e-17, 1e-12, 1e-8, 1e-6, 1e-4])
@pytest.mark.parametrize('steps', [1, 100])
def test_spin_near_the_intermediate_axis_follows_euler_equations(offset, steps):
    """A body with m a hair (down to round-off) off the intermediate axis.

    The body lingers by the axis for ~ln(|m| / offset) / lambda, so mc = 1 - k^2 is as small as
    ~offset^2. The flow still follows Euler's equations to round-off over 1 s, in one step or a
    hundred (scipy's ellipj, which takes only k^2, cannot resolve an mc that small). Offsets up
    to 1e-8 take the first-order expansion in mc, 1e-6 and 1e-4 the arithmetic-geometric mean.
    """
    m0 = np.array([offset, 10.0, -offset])
    m_ref, q_ref = near_axis_solution(m0, 1.0)
    m, q = m0[None], START[None]
    for _ in range(steps):
        m, q = torque_free_flow(MOMENTS[None], m, q, 1.0 / steps)
    assert quat_angle(q_ref, q[0]) <= 1e-11
    assert np.linalg.norm(m[0] - m_ref) <= 1e-12 * np.linalg.norm(m_ref)


@pytest.mark.parametrize('m0', [(0.02, 10.0, 0.04), (0.05, 10.0, 0.1), (0.1, 10.0, 0.3),
                                (0.3, 10.0, 0.6)])
@pytest.mark.parametrize('duration', [1e-3, 0.1])
def test_spin_just_outside_the_separatrix_band_is_exact_to_round_off(m0, duration):
    """Bodies with (L^2 - 2 E I2) / L^2 from 1e-6 to 3e-4: mc just above NEAR_SEPARATRIX.

    There sn and cn come from mc itself by the arithmetic-geometric mean; from k^2 = 1 - mc
    (as scipy's ellipj takes it) cn would carry an absolute error ~eps, which the
    third-kind integral's slope 1 / dn ~ 1 / sqrt(mc) turned into orientation errors of
    up to 5e-13 rad in one step. One step of 1 ms or 0.1 s follows Euler's equations to
    5e-14 rad and the momentum to 1e-15.
    """
    m0 = np.array(m0)
    m_ref, q_ref = near_axis_solution(m0, duration)
    m, q = torque_free_flow(MOMENTS[None], m0[None], START[None], duration)
    assert quat_angle(q_ref, q[0]) <= 5e-14
    assert np.linalg.norm(m[0] - m_ref) <= 1e-15 * np.linalg.norm(m_ref)


def random_bodies(n, seed):
    """Random moments (a few symmetric or on the separatrix), momenta and orientations."""
    rng = np.random.default_rng(seed)
    moments = rng.uniform(0.5, 3.0, (n, 3))
    moments[0, 1] = moments[0, 0]
    moments[1] = 1.7
    m = rng.normal(size=(n, 3))
    # Body 2 on the separatrix L^2 = 2 E I2 of I = (1, 2, 3), body 3 a hair off it.
    moments[2:4] = MOMENTS
    m[2:4] = [0.3, 1.0, 0.3 * np.sqrt(3.0)]
    m[3, 2] *= 1.0 + 1e-13
    q = rng.normal(size=(n, 4))
    return moments, m, q / np.linalg.norm(q, axis=1, keepdims=True)


def test_invariants_are_conserved_over_many_calls():
    """World L = R(q) m is constant, |q| = 1 and the kinetic energy is conserved.

    No NaN appears on or next to the separatrix.
    """
    moments, m, q = random_bodies(40, seed=7)
    l_world = quat_rotate(q, m)
    energy = np.sum(m ** 2 / moments, axis=1)
    for _ in range(300):
        m, q = torque_free_flow(moments, m, q, 0.037)
    assert np.all(np.isfinite(m)) and np.all(np.isfinite(q))
    scale = np.linalg.norm(l_world, axis=1)
    assert np.all(np.linalg.norm(quat_rotate(q, m) - l_world, axis=1) <= 1e-12 * scale)
    assert np.all(np.abs(np.linalg.norm(q, axis=1) - 1.0) <= 1e-13)
    assert np.allclose(np.sum(m ** 2 / moments, axis=1), energy, rtol=1e-12, atol=0.0)


def test_backward_step_undoes_forward_step():
    """The exact flow is time-reversible: advancing by -dt returns to the start."""
    moments, m0, q0 = random_bodies(20, seed=3)
    m, q = torque_free_flow(moments, m0, q0, 1.3)
    m, q = torque_free_flow(moments, m, q, -1.3)
    assert np.allclose(m, m0, rtol=0.0, atol=1e-12 * np.abs(m0).max())
    assert np.all(quat_angle(q0, q) <= 1e-12)


def test_rejects_bad_shapes():
    """Mismatched shapes and non-positive moments are refused with a reason."""
    with pytest.raises(ValueError):
        torque_free_flow(np.ones((2, 3)), np.ones((3, 3)), np.ones((2, 4)), 0.1)
    with pytest.raises(ValueError):
        torque_free_flow(np.ones((1, 3)), np.ones((1, 3)), np.ones((1, 3)), 0.1)
    with pytest.raises(ValueError):
        torque_free_flow([[0.0, 1.0, 1.0]], [[1.0, 0.0, 0.0]], [START], 0.1)
