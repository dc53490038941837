"""Exact torque-free motion of N rigid bodies (Jacobi elliptic functions, Carlson forms).

Quaternions are scalar-last ``(x, y, z, w)`` and map principal body axes to world axes.

Method (Celledoni, Fasso, Safstrom, Zanna, SIAM J. Sci. Comput. 2008; van Zon and
Schofield, J. Comput. Phys. 2007). Each body is turned into a *working* frame by a signed
permutation of its principal axes (a proper rotation, so Euler's equations keep their form):
axis 3 is the one ``m`` circles (the major axis when ``L^2 > 2 E I2``, else the minor one) and
``m1 >= 0``. There ``m = (a1 cn u, a2 sn u, +-a3 dn u)`` with ``u = u0 + lambda t``.
World ``L`` is fixed, so ``R(t) = Q Rz(psi(t)) B(m(t))`` with ``Q`` constant and
``B = Ry(-theta) Rz(-alpha)`` the Euler-angle rotation taking ``m`` to ``|L| e_z``; hence
``R(t1) = R(t0) B0^T Rz(dpsi) B1`` with
``dpsi = L dt/I3 + L (I3-I1)/(I1 I3 lambda) [Pi(-nu; am u)]_{u0}^{u1}``,
``nu = I3 (I2-I1)/(I1 (I3-I2))``: a third-kind integral, evaluated with ``elliprf``/``elliprj``.
Every amplitude enters only through ratios that stay finite for a pure spin (``a1 = a2 = 0``).

Axisymmetric and spherical bodies (and a spin about the intermediate axis, an equilibrium)
take the closed form ``R1 = R0 exp(m dt/I_perp) exp(e Omega dt)``; zero ``L`` is left alone.

Precision: the result is exact up to ~1e-15 relative per call times the phase
``|lambda| dt``. Near the separatrix the complementary parameter ``mc = 1 - k^2`` is computed
from ``L^2 - 2 E I2`` without cancellation and used for ``K``, ``u0`` and ``dn``, but
``scipy.special.ellipj`` takes ``k^2`` itself, so the phase error grows like
``eps * (half-periods travelled) / mc``; the state itself fixes ``mc`` only to relative
``eps / mc``, so this is the conditioning of the problem, not a loss of the method.
No NaN is produced for ``mc -> 0`` (on the separatrix ``K = inf`` and no period is reduced).
"""
import numpy as np
from scipy.special import ellipj, ellipkm1, elliprf, elliprj
from scipy.spatial.transform import Rotation

from rigid_sim.core import rotation

# Moments closer than this (relative) are treated as equal: a few ulps, where the closed form
# errs by ~1e-14 of the angle turned; the elliptic form stays ~1e-12 accurate down to 1e-14 gaps.
SYMMETRY_RTOL = 1e-14
# Proper rotation (x, y, z) -> (z, y, -x): makes the minor axis the working axis 3.
SWAP_MAJOR_MINOR = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
# Half-turn about axis 3: makes m1 >= 0 so u0 = F(am0) needs no period (K may be infinite).
HALF_TURN_Z = np.diag([-1.0, -1.0, 1.0])
AXES = np.eye(3)
# Entries of a signed permutation matrix, each in {-1, 0, 1}, read as a base-3 number (a key).
_KEY_DIGITS = 3 ** np.arange(9)


def _signed_permutation_quaternions():
    """Table: key of each proper signed permutation matrix -> its quaternion (x, y, z, w).

    The working frames are these 24 matrices only, so one lookup replaces a general (and,
    per call, ~100x dearer) matrix-to-quaternion conversion.
    """
    permutations = np.array([np.eye(3)[list(p)] for p in np.ndindex(3, 3, 3)
                             if len(set(p)) == 3])
    signs = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T
    frames = (permutations[:, None] * signs[None, :, :, None]).reshape(-1, 3, 3)
    frames = frames[np.linalg.det(frames) > 0.0]
    table = np.full((3 ** 9, 4), np.nan)
    table[_frame_keys(frames)] = Rotation.from_matrix(frames).as_quat()
    return table


def _frame_keys(frames):
    """Keys (N,) int of (N, 3, 3) signed permutation matrices."""
    return (np.rint(frames.reshape(-1, 9)) + 1.0).astype(int) @ _KEY_DIGITS


_FRAME_QUATERNIONS = _signed_permutation_quaternions()


def torque_free_flow(moments, angular_momentum_body, orientation, dt):
    """Advance N torque-free rigid bodies exactly by dt.

    Parameters
    ----------
    moments : (N, 3) float
        Principal moments of inertia, any order, positive; symmetric or spherical allowed.
    angular_momentum_body : (N, 3) float
        Angular momentum in the principal body axes (same axes as ``moments``).
    orientation : (N, 4) float
        Unit quaternions ``(x, y, z, w)`` mapping principal body axes to world axes.
    dt : float
        Time step, s (may be negative).

    Returns
    -------
    angular_momentum_body_new : (N, 3) float
    orientation_new : (N, 4) float
        Unit quaternions, continuous in ``dt`` from ``orientation``.
    """
    moments = np.asarray(moments, dtype=float)
    m = np.asarray(angular_momentum_body, dtype=float)
    q = np.asarray(orientation, dtype=float)
    if moments.ndim != 2 or moments.shape[1] != 3 or m.shape != moments.shape:
        raise ValueError('moments and angular_momentum_body must both be (N, 3)')
    if q.shape != (len(m), 4):
        raise ValueError('orientation must be (N, 4) quaternions (x, y, z, w)')
    if np.any(moments <= 0.0):
        raise ValueError('principal moments must be positive')
    # Scale-free: flow(m, I, dt) == flow(m/a, I/b, dt a/b) scaled back; avoids over/underflow.
    m_scale = np.max(np.abs(m), axis=1)
    i_scale = np.max(moments, axis=1)
    moving = m_scale > 0.0
    m_new, q_new = m.copy(), q.copy()
    if np.any(moving):
        safe = np.where(moving, m_scale, 1.0)[:, None]
        time = dt * m_scale / i_scale
        m_unit = m / safe
        step = np.zeros_like(q)
        m_next = np.zeros_like(m)
        symmetric, axis, i_axis, i_perp = _classify(moments / i_scale[:, None], m_unit)
        sym = moving & symmetric
        ell = moving & ~symmetric
        if np.any(sym):   # an empty branch would still cost its ~50 numpy calls
            m_next[sym], step[sym] = _axisymmetric(
                axis[sym], i_axis[sym], i_perp[sym], m_unit[sym], time[sym])
        if np.any(ell):
            m_next[ell], step[ell] = _asymmetric(
                moments[ell] / i_scale[ell, None], m_unit[ell], time[ell])
        m_new[moving] = m_next[moving] * safe[moving]
        q_new[moving] = rotation.multiply(q[moving], step[moving])
    return m_new, rotation.normalize(q_new)


def _classify(moments, m):
    """Which bodies take the closed form, and its symmetry axis, I_axis and I_perp.

    Returns symmetric (N,) bool, axis (N, 3) unit body vector, i_axis (N,), i_perp (N,).
    """
    order = np.argsort(moments, axis=1)
    s = np.take_along_axis(moments, order, axis=1)
    m_sorted = np.take_along_axis(m, order, axis=1)
    equal_12 = s[:, 1] - s[:, 0] <= SYMMETRY_RTOL * s[:, 2]
    equal_23 = s[:, 2] - s[:, 1] <= SYMMETRY_RTOL * s[:, 2]
    # m along the intermediate axis: an (unstable) equilibrium, a pure spin.
    saddle = (m_sorted[:, 0] ** 2 == 0.0) & (m_sorted[:, 2] ** 2 == 0.0)
    index = np.where(equal_23 & ~equal_12, order[:, 0], order[:, 2])
    index = np.where(saddle & ~equal_12 & ~equal_23, order[:, 1], index)
    i_axis = np.take_along_axis(moments, index[:, None], axis=1)[:, 0]
    i_perp = np.where(equal_23, 0.5 * (s[:, 1] + s[:, 2]), 0.5 * (s[:, 0] + s[:, 1]))
    i_perp = np.where(saddle & ~equal_12 & ~equal_23, s[:, 0], i_perp)
    i_axis = np.where(equal_12 & equal_23, i_perp, i_axis)
    return equal_12 | equal_23 | saddle, AXES[index], i_axis, i_perp


def _axisymmetric(axis, i_axis, i_perp, m, time):
    """Closed-form free motion of symmetric tops: body rotation and new m (working units).

    ``omega = m / I_perp + Omega e`` with ``Omega = (m.e)(1/I_axis - 1/I_perp)`` constant; the
    first part turns about the fixed world L, the second about the body axis, so
    ``R(t) = R0 exp(m0 t / I_perp) exp(e Omega t)`` and ``m(t) = Rot(e, -Omega t) m0``.
    """
    spin = np.sum(m * axis, axis=1) * (1.0 / i_axis - 1.0 / i_perp)
    angle = -(spin * time)[:, None]
    m_new = (m * np.cos(angle) + np.cross(axis, m) * np.sin(angle)
             + axis * np.sum(axis * m, axis=1, keepdims=True) * (1.0 - np.cos(angle)))
    step = rotation.multiply(rotation.exp_map(m * (time / i_perp)[:, None]),
                             rotation.exp_map(axis * (spin * time)[:, None]))
    return m_new, step


def _working_frame(moments, m):
    """Signed permutation P (proper) to the working frame; moments and m there."""
    order = np.argsort(moments, axis=1)
    frame = AXES[order]
    frame[np.linalg.det(frame) < 0.0, 0] *= -1.0
    i_w = np.take_along_axis(moments, order, axis=1)
    m_w = np.einsum('nij,nj->ni', frame, m)
    # L^2 - 2 E I2 < 0: m circles the minor axis.
    minor = _separatrix_gap(i_w, m_w) < 0.0
    frame[minor] = SWAP_MAJOR_MINOR @ frame[minor]
    i_w[minor] = i_w[minor, ::-1]
    m_w = np.einsum('nij,nj->ni', frame, m)
    flip = m_w[:, 0] < 0.0
    frame[flip] = HALF_TURN_Z @ frame[flip]
    m_w[flip, :2] *= -1.0
    return frame, i_w, m_w


def _separatrix_gap(i, m):
    """``L^2 - 2 E I2``, summed without cancelling the I2 term."""
    return (m[:, 0] ** 2 * (i[:, 0] - i[:, 1]) / i[:, 0]
            + m[:, 2] ** 2 * (i[:, 2] - i[:, 1]) / i[:, 2])


def _asymmetric(moments, m, time):
    """Elliptic free motion of asymmetric bodies: new m and body-frame rotation step."""
    frame, i_w, m_w = _working_frame(moments, m)
    m_w_new, core = _elliptic_working(i_w, m_w, time)
    m_new = np.einsum('nji,nj->ni', frame, m_w_new)
    p = _FRAME_QUATERNIONS[_frame_keys(frame)]
    step = rotation.multiply(rotation.multiply(rotation.conjugate(p), core), p)
    return m_new, step


def _invariants(i, m):
    """Squared amplitudes and parameters of m(t) in the working frame (see module doc)."""
    i1, i2, i3 = i.T
    m1, m2, m3 = (m ** 2).T
    above = m1 * (i3 - i1) / i1 + m2 * (i3 - i2) / i2   # 2 E I3 - L^2, no cancellation
    below = m2 * (i2 - i1) / i2 + m3 * (i3 - i1) / i3   # L^2 - 2 E I1, no cancellation
    k2 = np.clip(above * (i2 - i1) / (below * (i3 - i2)), 0.0, 1.0)
    mc = np.clip((i3 - i1) * _separatrix_gap(i, m) / (below * (i3 - i2)), 0.0, 1.0)
    amplitude = np.sqrt(np.stack((above * i1 / (i3 - i1), above * i2 / (i3 - i2),
                                  below * i3 / (i3 - i1)), axis=1))
    rate = np.sign(m[:, 2]) * np.sign(i3 - i1) * np.sqrt(below * (i3 - i2) / (i1 * i2 * i3))
    rate = np.where(m[:, 2] == 0.0, np.abs(rate), rate)
    return k2, mc, amplitude, rate


def _pi_minus(nu, s, c, dn2):
    """Legendre ``Pi(-nu; phi | k^2)`` for |phi| <= pi/2 from sin, cos and dn^2 of phi."""
    return s * elliprf(c * c, dn2, 1.0) - nu / 3.0 * s ** 3 * elliprj(c * c, dn2, 1.0,
                                                                      1.0 + nu * s * s)


def _elliptic_working(i, m, time):
    """Advance m and build ``B0^T Rz(dpsi) B1`` (quaternion) in the working frame."""
    i1, i2, i3 = i.T
    k2, mc, amp, rate = _invariants(i, m)
    ratio = np.sqrt(i1 * (i3 - i2) / (i2 * (i3 - i1)))   # a1 / a2, finite for a pure spin
    nu = i3 * (i2 - i1) / (i1 * (i3 - i2))
    h = np.hypot(ratio * m[:, 1], m[:, 0])
    s0 = np.where(h > 0.0, ratio * m[:, 1] / np.where(h > 0.0, h, 1.0), 0.0)
    c0 = np.where(h > 0.0, m[:, 0] / np.where(h > 0.0, h, 1.0), 1.0)
    u0 = s0 * elliprf(c0 * c0, c0 * c0 + mc * s0 * s0, 1.0)   # F(am0), |am0| <= pi/2
    u1 = u0 + rate * time
    quarter = ellipkm1(mc)   # K, from mc directly (inf on the separatrix)
    with np.errstate(invalid='ignore', divide='ignore'):
        turns = np.where(np.isfinite(quarter), np.round(u1 / (2.0 * quarter)), 0.0)
        shift = np.where(turns != 0.0, 2.0 * turns * quarter, 0.0)
        sn, cn, dn, _ = ellipj(u1 - shift, k2)
        dn2 = cn * cn + mc * sn * sn
        complete = elliprf(0.0, mc, 1.0) - nu / 3.0 * elliprj(0.0, mc, 1.0, 1.0 + nu)
        g1 = np.where(turns != 0.0, 2.0 * turns * complete, 0.0) + _pi_minus(nu, sn, cn, dn2)
    g0 = _pi_minus(nu, s0, c0, c0 * c0 + mc * s0 * s0)
    sign = 1.0 - 2.0 * np.mod(turns, 2.0)
    m_new = np.stack((amp[:, 0] * sign * cn, amp[:, 1] * sign * sn,
                      np.where(m[:, 2] < 0.0, -1.0, 1.0) * amp[:, 2] * np.sqrt(dn2)), axis=1)
    big_l = np.linalg.norm(m, axis=1)
    dpsi = big_l * time / i3 + big_l * (i3 - i1) / (i1 * i3 * rate) * (g1 - g0)
    alpha0 = np.arctan2(s0, ratio * c0)
    alpha1 = turns * np.pi + np.arctan2(sn, ratio * cn)
    core = rotation.multiply(_zyz(alpha0, _polar(m), dpsi),
                             rotation.conjugate(_zyz(alpha1, _polar(m_new), 0.0)))
    return m_new, core


def _polar(m):
    """Angle between m and the working axis 3, in [0, pi]."""
    return np.arctan2(np.hypot(m[:, 0], m[:, 1]), m[:, 2])


def _zyz(a, b, c):
    """Quaternions ``(x, y, z, w)`` of ``Rz(a) Ry(b) Rz(c)``, (N,) angles each."""
    half_b = 0.5 * b
    diff, total = 0.5 * (c - a), 0.5 * (a + c)
    return np.stack((np.sin(half_b) * np.sin(diff), np.sin(half_b) * np.cos(diff),
                     np.cos(half_b) * np.sin(total), np.cos(half_b) * np.cos(total)), axis=1)
