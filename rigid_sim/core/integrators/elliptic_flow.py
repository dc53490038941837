# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The elliptic branch of the exact free flow, in a body's working frame.

See :mod:`~rigid_sim.core.integrators.free_rotation` for the method and the working frame
(``I1 < I2 < I3`` or reversed, ``m1 >= 0``); quaternions are scalar-last ``(x, y, z, w)``.
"""
import numpy as np
from scipy.special import ellipj, ellipkm1, elliprf, elliprj

from rigid_sim.core import rotation

# Near the separatrix (a spin close to the intermediate axis) cn(u) is as small as
# ~sqrt(mc) over most of a period, and the orientation needs it to its own relative accuracy:
# the third-kind integral's slope there is 1 / dn ~ 1 / sqrt(mc). scipy's ellipj takes only
# m = 1 - mc and returns cn = cos(am u) to an absolute eps: an orientation error of
# ~eps / sqrt(mc) per step (1e-4 rad at mc ~ 1e-24, O(1) once m rounds to 1; 1e-13 at this
# mc). Below it, sn and cn come from mc itself.
NEAR_SEPARATRIX = 1e-6
# Below this mc, sn and cn on [0, K/2] are tanh and sech with their first-order correction in
# mc (Abramowitz and Stegun 16.15), whose error there is below ~16 mc relative.
EXPANSION_MC = 1e-16
# The arithmetic-geometric mean stops once c_n / a_n is below this: it converges
# quadratically, so the next ratio would be ~1e-18, and rounding keeps c_n ~ eps a_n from
# ever falling much below that (about 9 steps from mc = 1e-30, 12 from mc = 1e-300).
AGM_TOL = 1e-9
AGM_MAX_STEPS = 64


def separatrix_gap(i, m):
    """``L^2 - 2 E I2``, summed without cancelling the I2 term."""
    return (m[:, 0] ** 2 * (i[:, 0] - i[:, 1]) / i[:, 0]
            + m[:, 2] ** 2 * (i[:, 2] - i[:, 1]) / i[:, 2])


def _invariants(i, m):
    """Squared amplitudes and parameters of m(t) in the working frame (see module doc)."""
    i1, i2, i3 = i.T
    m1, m2, m3 = (m ** 2).T
    above = m1 * (i3 - i1) / i1 + m2 * (i3 - i2) / i2   # 2 E I3 - L^2, no cancellation
    below = m2 * (i2 - i1) / i2 + m3 * (i3 - i1) / i3   # L^2 - 2 E I1, no cancellation
    k2 = np.clip(above * (i2 - i1) / (below * (i3 - i2)), 0.0, 1.0)
    mc = np.clip((i3 - i1) * separatrix_gap(i, m) / (below * (i3 - i2)), 0.0, 1.0)
    amplitude = np.sqrt(np.stack((above * i1 / (i3 - i1), above * i2 / (i3 - i2),
                                  below * i3 / (i3 - i1)), axis=1))
    rate = np.sign(m[:, 2]) * np.sign(i3 - i1) * np.sqrt(below * (i3 - i2) / (i1 * i2 * i3))
    rate = np.where(m[:, 2] == 0.0, np.abs(rate), rate)
    return k2, mc, amplitude, rate


def _first_kind(s, c, dn2):
    """Legendre ``F(phi | k^2)`` for |phi| <= pi/2 from sin, cos and dn^2 of phi."""
    return s * elliprf(c * c, dn2, 1.0)


def _pi_minus(nu, s, c, dn2, first_kind):
    """Legendre ``Pi(-nu; phi | k^2)`` for |phi| <= pi/2.

    ``first_kind`` is ``F(phi | k^2)``, the Carlson R_F part the two integrals share.
    """
    return first_kind - nu / 3.0 * s ** 3 * elliprj(c * c, dn2, 1.0, 1.0 + nu * s * s)


def _complete_pi_minus(nu, mc, turns):
    """``Pi(-nu | k^2)`` where ``turns`` is non-zero, else 0.

    Only a body that passes a half period in the step needs it, and at small steps few do (each
    costs two Carlson calls).
    """
    complete = np.zeros_like(mc)
    passing = turns != 0.0
    if passing.any():
        nu_p, mc_p = nu[passing], mc[passing]
        complete[passing] = (elliprf(0.0, mc_p, 1.0)
                             - nu_p / 3.0 * elliprj(0.0, mc_p, 1.0, 1.0 + nu_p))
    return complete


def _sn_cn_complementary(u, mc):
    """Jacobi ``sn`` and ``cn`` of ``u`` (N,) at parameter ``m = 1 - mc``, from ``mc`` (N,).

    Descending Gauss transformation (Abramowitz and Stegun 16.4): the arithmetic-geometric
    mean of (1, sqrt(mc)) gives a_n and c_n = (a_{n-1} - b_{n-1}) / 2 until c_N vanishes;
    then phi_N = 2^N a_N u and ``phi_{n-1} = (phi_n + arcsin(c_n / a_n sin phi_n)) / 2``
    down to the amplitude phi_0: sn = sin phi_0, cn = cos phi_0. Started from mc itself, it
    keeps the accuracy scipy's ``ellipj(u, 1 - mc)`` loses for small mc. Needs mc > 0.
    """
    a, b = np.ones_like(mc), np.sqrt(mc)
    ratios = []
    for _ in range(AGM_MAX_STEPS):
        c = 0.5 * (a - b)
        a, b = 0.5 * (a + b), np.sqrt(a * b)
        ratios.append(c / a)
        if np.all(ratios[-1] < AGM_TOL):
            break
    phi = 2.0 ** len(ratios) * a * u
    for ratio in reversed(ratios):
        phi = 0.5 * (phi + np.arcsin(ratio * np.sin(phi)))
    return np.sin(phi), np.cos(phi)


def _sn_cn_first_order(u, mc):
    """Return ``sn``, ``cn`` of ``u`` to first order in a tiny ``mc`` (A&S 16.15.1-2).

    Each is accurate relative to its own size for |u| <= K/2.
    """
    sech, tanh = 1.0 / np.cosh(u), np.tanh(u)
    correction = 0.25 * mc * (np.sinh(u) * np.cosh(u) - u) * sech
    return tanh + correction * sech, sech - correction * tanh


def _sn_cn_near_separatrix(v, mc, quarter):
    """Return ``sn``, ``cn`` of ``v`` (|v| <= K) for 0 < mc < NEAR_SEPARATRIX.

    cn is accurate relative to its own size. Beyond K/2, ``sn(K - w) = cd(w)`` and
    ``cn(K - w) = sqrt(mc) sd(w)`` (A&S 16.8) give cn as sqrt(mc) times a number of order one,
    not as the cosine of an angle near pi/2.
    """
    far = np.abs(v) > 0.5 * quarter
    w = np.where(far, quarter - np.abs(v), np.abs(v))
    tiny = mc < EXPANSION_MC
    sn_w, cn_w = np.empty_like(w), np.empty_like(w)
    sn_w[tiny], cn_w[tiny] = _sn_cn_first_order(w[tiny], mc[tiny])
    sn_w[~tiny], cn_w[~tiny] = _sn_cn_complementary(w[~tiny], mc[~tiny])
    dn_w = np.sqrt(cn_w * cn_w + mc * sn_w * sn_w)
    sn = np.where(far, cn_w / dn_w, sn_w)
    cn = np.where(far, np.sqrt(mc) * sn_w / dn_w, cn_w)
    return np.sign(v) * sn, cn


def _jacobi_sn_cn(v, k2, mc, quarter):
    """``sn``, ``cn`` of the reduced ``v`` (|v| <= K) at ``k^2``.

    scipy's ``ellipj``, or from ``mc`` near the separatrix (on it, mc = 0, ellipj's tanh and sech
    are exact).
    """
    sn, cn, _, _ = ellipj(v, k2)
    near = (mc > 0.0) & (mc < NEAR_SEPARATRIX)
    if near.any():   # rare: skip the ~40 numpy calls of an empty branch
        sn[near], cn[near] = _sn_cn_near_separatrix(v[near], mc[near], quarter[near])
    return sn, cn


def shape_constants(i):
    """``a1 / a2`` (finite for a pure spin) and ``nu`` of working-frame moments (N, 3)."""
    i1, i2, i3 = i.T
    return np.sqrt(i1 * (i3 - i2) / (i2 * (i3 - i1))), i3 * (i2 - i1) / (i1 * (i3 - i2))


def elliptic_working(i, m, time, ratio, nu):
    """Advance m and build ``B0^T Rz(dpsi) B1`` (quaternion) in the working frame.

    ``i`` (N, 3) working-frame moments, ``m`` (N, 3), ``time`` (N,), and ``ratio``, ``nu``
    (N,) from :func:`shape_constants` of ``i``. Returns m (N, 3) and the quaternion (N, 4).
    """
    i1, i2, i3 = i.T
    k2, mc, amp, rate = _invariants(i, m)
    h = np.hypot(ratio * m[:, 1], m[:, 0])
    s0 = np.where(h > 0.0, ratio * m[:, 1] / np.where(h > 0.0, h, 1.0), 0.0)
    c0 = np.where(h > 0.0, m[:, 0] / np.where(h > 0.0, h, 1.0), 1.0)
    dn0_2 = c0 * c0 + mc * s0 * s0
    u0 = _first_kind(s0, c0, dn0_2)   # F(am0), |am0| <= pi/2
    u1 = u0 + rate * time
    quarter = ellipkm1(mc)   # K, from mc directly (inf on the separatrix)
    with np.errstate(invalid='ignore', divide='ignore'):
        turns = np.where(np.isfinite(quarter), np.round(u1 / (2.0 * quarter)), 0.0)
        shift = np.where(turns != 0.0, 2.0 * turns * quarter, 0.0)
        sn, cn = _jacobi_sn_cn(u1 - shift, k2, mc, quarter)
        dn2 = cn * cn + mc * sn * sn
        # F(am v) = v for |v| <= K: the reduced argument is its own first-kind integral.
        g1 = (2.0 * turns * _complete_pi_minus(nu, mc, turns)
              + _pi_minus(nu, sn, cn, dn2, u1 - shift))
    g0 = _pi_minus(nu, s0, c0, dn0_2, u0)
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
