# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The elliptic branch of the exact free flow, in a body's working frame, compiled per body.

See :mod:`~rigid_sim.core.integrators.free_rotation` for the method and the working frame
(``I1 < I2 < I3`` or reversed, ``m1 >= 0``); quaternions are scalar-last ``(x, y, z, w)``,
3-vectors and moments are 3-tuples.
"""
import math

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper
from rigid_sim.core.special import ellipkm1, elliprf, elliprj, sn_cn

# Near the separatrix (a spin close to the intermediate axis) cn(u) is as small as
# ~sqrt(mc) over most of a period, and the orientation needs it to its own relative accuracy:
# the third-kind integral's slope there is 1 / dn ~ 1 / sqrt(mc). The descending Gauss
# transformation returns cn = cos(am u) to an absolute eps: an orientation error of
# ~eps / sqrt(mc) per step (1e-4 rad at mc ~ 1e-24; 1e-13 at this mc). Below it, cn comes
# from sd near a quarter period, a number of order one times sqrt(mc).
NEAR_SEPARATRIX = 1e-6
# Below this mc, sn and cn on [0, K/2] are tanh and sech with their first-order correction in
# mc (Abramowitz and Stegun 16.15), whose error there is below ~16 mc relative.
EXPANSION_MC = 1e-16
# The largest ``prefactor / dn`` (the slope of the precession angle in the rounding of sn and
# cn) at which the third-kind integral takes F(am v) = v: at most ~1e3 eps (2e-13 rad) of
# angle; beyond, F is computed from sn and cn (see :func:`elliptic_working`).
ROUNDED_PHASE = 1e-3


@helper
def separatrix_gap(i, m):
    """``L^2 - 2 E I2``, summed without cancelling the I2 term."""
    return m[0] ** 2 * (i[0] - i[1]) / i[0] + m[2] ** 2 * (i[2] - i[1]) / i[2]


@helper
def _sign(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@helper
def _unit_interval(x):
    return min(max(x, 0.0), 1.0)


@helper
def _invariants(i, m):
    """Complementary parameter mc, squared amplitudes' roots (3-tuple) and rate of m(t)."""
    i1, i2, i3 = i
    m1, m2, m3 = m[0] ** 2, m[1] ** 2, m[2] ** 2
    above = m1 * (i3 - i1) / i1 + m2 * (i3 - i2) / i2   # 2 E I3 - L^2, no cancellation
    below = m2 * (i2 - i1) / i2 + m3 * (i3 - i1) / i3   # L^2 - 2 E I1, no cancellation
    mc = _unit_interval((i3 - i1) * separatrix_gap(i, m) / (below * (i3 - i2)))
    amplitude = (math.sqrt(above * i1 / (i3 - i1)), math.sqrt(above * i2 / (i3 - i2)),
                 math.sqrt(below * i3 / (i3 - i1)))
    rate = math.sqrt(below * (i3 - i2) / (i1 * i2 * i3))
    if m[2] != 0.0:
        rate *= _sign(m[2]) * _sign(i3 - i1)
    return mc, amplitude, rate


@helper
def _pi_minus(nu, s, c, dn2, first_kind):
    """Evaluate Legendre's ``Pi(-nu; phi | k^2)`` for |phi| <= pi/2.

    ``s``, ``c`` and ``dn2`` are sin, cos and dn^2 of phi; ``first_kind`` is
    ``F(phi | k^2)``, the Carlson R_F part the two integrals share.
    """
    return first_kind - nu / 3.0 * s ** 3 * elliprj(c * c, dn2, 1.0, 1.0 + nu * s * s)


@helper
def _sn_cn_first_order(u, mc):
    """Evaluate ``sn`` and ``cn`` of ``u`` to first order in a tiny ``mc`` (A&S 16.15.1-2).

    Each is accurate to its own relative precision for |u| <= K/2.
    """
    sech, tanh = 1.0 / math.cosh(u), math.tanh(u)
    correction = 0.25 * mc * (math.sinh(u) * math.cosh(u) - u) * sech
    return tanh + correction * sech, sech - correction * tanh


@helper
def _sn_cn_near_separatrix(v, mc, quarter):
    """Evaluate ``sn`` and ``cn`` of ``v`` (|v| <= K) for 0 < mc < NEAR_SEPARATRIX.

    cn comes out to its relative accuracy. Beyond K/2, ``sn(K - w) = cd(w)`` and
    ``cn(K - w) = sqrt(mc) sd(w)`` (A&S 16.8) give cn as sqrt(mc) times a number of order
    one, not as the cosine of an angle near pi/2.
    """
    far = abs(v) > 0.5 * quarter
    w = quarter - abs(v) if far else abs(v)
    if mc < EXPANSION_MC:
        sn_w, cn_w = _sn_cn_first_order(w, mc)
    else:
        sn_w, cn_w = sn_cn(w, mc)
    dn_w = math.sqrt(cn_w * cn_w + mc * sn_w * sn_w)
    if far:
        return _sign(v) * cn_w / dn_w, math.sqrt(mc) * sn_w / dn_w
    return _sign(v) * sn_w, cn_w


@helper
def _jacobi_sn_cn(v, mc, quarter):
    """Evaluate ``sn`` and ``cn`` of the reduced ``v`` (|v| <= K) at ``m = 1 - mc``.

    On the separatrix (mc = 0) they are tanh and sech; near it cn is kept to its relative
    accuracy (:func:`_sn_cn_near_separatrix`).
    """
    if mc == 0.0:
        return math.tanh(v), 1.0 / math.cosh(v)
    if mc < NEAR_SEPARATRIX:
        return _sn_cn_near_separatrix(v, mc, quarter)
    return sn_cn(v, mc)


@helper
def shape_constants(i):
    """Return ``a1 / a2`` (finite for a pure spin) and ``nu`` of working-frame moments ``i``."""
    i1, i2, i3 = i
    return math.sqrt(i1 * (i3 - i2) / (i2 * (i3 - i1))), i3 * (i2 - i1) / (i1 * (i3 - i2))


@helper
def elliptic_working(i, m, time, ratio, nu):
    """Advance m and build ``B0^T Rz(dpsi) B1`` in the working frame.

    Parameters
    ----------
    i : 3-tuple of float
        Principal moments in the working frame, scaled, ``I1 < I2 < I3`` or reversed.
    m : 3-tuple of float
        Angular momentum in the working frame, scaled, ``m1 >= 0``.
    time : float
        Scaled time of the step.
    ratio : float
        ``a1 / a2`` of ``i``, from :func:`shape_constants`.
    nu : float
        Characteristic of the third-kind integral, from :func:`shape_constants` of ``i``.

    Returns
    -------
    m : 3-tuple of float
        The angular momentum after ``time``, working frame.
    core : 4-tuple of float
        Quaternion (x, y, z, w) of the step's rotation in the working frame.
    """
    mc, amp, rate = _invariants(i, m)
    h = math.hypot(ratio * m[1], m[0])
    s0 = ratio * m[1] / h if h > 0.0 else 0.0
    c0 = m[0] / h if h > 0.0 else 1.0
    dn0_2 = c0 * c0 + mc * s0 * s0
    u0 = s0 * elliprf(c0 * c0, dn0_2, 1.0)   # F(am0), |am0| <= pi/2
    u1 = u0 + rate * time
    quarter = ellipkm1(mc)   # K, from mc directly (inf on the separatrix)
    turns = np.rint(u1 / (2.0 * quarter)) if math.isfinite(quarter) else 0.0
    shift = 2.0 * turns * quarter if turns != 0.0 else 0.0
    v = u1 - shift
    sn, cn = _jacobi_sn_cn(v, mc, quarter)
    dn2 = cn * cn + mc * sn * sn
    complete = 0.0   # Pi(-nu | k^2): only a body passing a half period needs it
    if turns != 0.0:
        complete = elliprf(0.0, mc, 1.0) - nu / 3.0 * elliprj(0.0, mc, 1.0, 1.0 + nu)
    big_l = math.sqrt(kin.dot(m, m))
    i1, i3 = i[0], i[2]
    prefactor = big_l * (i3 - i1) / (i1 * i3 * rate)
    # F(am v) is v for |v| <= K. Pi's two parts cancel (Pi's slope in am is
    # 1 / ((1 + nu sn^2) dn)), each with a slope 1 / dn: with F = v, the rounding of sn and
    # cn entered the R_J part alone, and the angle by ~eps prefactor / dn. Where that exceeds
    # ROUNDED_PHASE eps, F is taken from the same sn and cn (one more R_F): on a thin rod
    # (I = 1e-4, 1, 1.0001; nu = 1e8, mc = 1e-6, prefactor / dn ~ 1e7) the step erred by up to
    # 5e-10 against a 40-digit Taylor solution, 3.6e-11 with it.
    first_kind = v
    if not abs(prefactor) * ROUNDED_PHASE < math.sqrt(dn2):
        first_kind = sn * elliprf(cn * cn, dn2, 1.0)
    g1 = 2.0 * turns * complete + _pi_minus(nu, sn, cn, dn2, first_kind)
    g0 = _pi_minus(nu, s0, c0, dn0_2, u0)
    sign = 1.0 - 2.0 * (turns - 2.0 * math.floor(0.5 * turns))
    m_new = (amp[0] * sign * cn, amp[1] * sign * sn,
             (-1.0 if m[2] < 0.0 else 1.0) * amp[2] * math.sqrt(dn2))
    dpsi = big_l * time / i3 + prefactor * (g1 - g0)
    # Euler angles enter only halved, so each is kept as (cos, sin) of its half: from the
    # vectors that define it, with square roots, where angles cost an atan2 and two sines.
    half_alpha0 = _half_angle(ratio * c0, s0)
    half_alpha1 = _quarter_turns(_half_angle(ratio * cn, sn), turns)
    half_dpsi = (math.cos(0.5 * dpsi), math.sin(0.5 * dpsi))
    core = kin.multiply(_zyz(half_alpha0, _half_polar(m), half_dpsi),
                        kin.conjugate(_zyz(half_alpha1, _half_polar(m_new), (1.0, 0.0))))
    return m_new, core


@helper
def _half_angle(c, s):
    """``(cos, sin)`` of half of ``atan2(s, c)`` (in (-pi, pi]; (1, 0) for c = s = 0).

    Of ``cos theta/2 = sqrt((1 + cos theta) / 2)`` and ``sin theta/2 = sqrt((1 - cos theta) /
    2)``, the larger is taken from its root and the smaller from ``sin theta = 2 cos sin``, so
    neither loses digits where the other is near zero. ``c`` and ``s`` are of order one (the
    flow's are scaled), so their squares neither overflow nor underflow.
    """
    r = math.sqrt(c * c + s * s)
    if r == 0.0:
        return 1.0, 0.0
    if c >= 0.0:
        cos_half = math.sqrt(0.5 * (1.0 + c / r))
        return cos_half, 0.5 * s / (r * cos_half)
    sin_half = math.sqrt(0.5 * (1.0 - c / r))
    return 0.5 * abs(s) / (r * sin_half), math.copysign(sin_half, s)


@helper
def _quarter_turns(half, turns):
    """``half`` (cos, sin) turned by ``turns`` quarter turns: half of ``turns`` half turns."""
    k = turns - 4.0 * math.floor(0.25 * turns)
    c, s = half
    if k == 1.0:
        return -s, c
    if k == 2.0:
        return -c, -s
    if k == 3.0:
        return s, -c
    return c, s


@helper
def _half_polar(m):
    """``(cos, sin)`` of half the angle between m and the working axis 3 (in [0, pi])."""
    return _half_angle(m[2], math.sqrt(m[0] * m[0] + m[1] * m[1]))


@helper
def _zyz(a, b, c):
    """Quaternion ``(x, y, z, w)`` of ``Rz(alpha) Ry(beta) Rz(gamma)``.

    ``a``, ``b`` and ``c`` are (cos, sin) of alpha / 2, beta / 2 and gamma / 2.
    """
    sin_diff, cos_diff = c[1] * a[0] - c[0] * a[1], c[0] * a[0] + c[1] * a[1]
    sin_total, cos_total = a[1] * c[0] + a[0] * c[1], a[0] * c[0] - a[1] * c[1]
    return (b[1] * sin_diff, b[1] * cos_diff, b[0] * sin_total, b[0] * cos_total)
