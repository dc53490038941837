# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Elliptic functions inside compiled code: scipy's K, Jacobi's sn and cn, Carlson's R_F, R_J.

``ellipkm1`` is that of ``scipy.special.cython_special``. The others are written out here,
where the free flow calls them per body and drift and scipy's cost more for the same
double-precision result (docs/performance.md has the timings). The tests compare them with
scipy's and, where scipy's lose digits (sn and cn at small ``mc``, R_J with ``p`` far below
the others), with mpmath's at high precision. ``sn`` and ``cn`` come from the complementary
parameter ``mc`` itself (scipy's ``ellipj`` takes ``m = 1 - mc``, which rounds small ``mc``
away). Carlson's symmetric integrals are his duplication method (B. C. Carlson, Numerical
Algorithms 10, 1995; the series and tolerances as in Numerical Recipes 3rd ed., 6.12).

The C function is registered with LLVM under a symbol of its own and declared to numba as
an external function of that name, so compiled code refers to it by name, not by an
address: that keeps ``cache=True`` working (an address is valid only in the process that
took it). The registration runs at import, before any cached kernel is loaded.
"""
import math

import llvmlite.binding as llvm
from numba import carray, types
from numba.core import cgutils
from numba.extending import get_cython_function_address, intrinsic

from rigid_sim.core.compiled import helper, kernel

_SYMBOL = 'rigid_sim_ellipkm1'
llvm.add_symbol(_SYMBOL, get_cython_function_address('scipy.special.cython_special', 'ellipkm1'))
# The signature's trailing int is Cython's skip-dispatch flag.
_ellipkm1 = types.ExternalFunction(_SYMBOL, types.double(types.double, types.intc))
# The arithmetic-geometric mean stops once c_n / a_n is below this: it converges
# quadratically, so the next ratio would be ~1e-18, and rounding keeps c_n ~ eps a_n from
# ever falling much below that (about 9 steps from mc = 1e-30, 12 from mc = 1e-300).
AGM_TOL = 1e-9
AGM_MAX_STEPS = 64
# Duplication stops when every argument is within this of their mean: the truncated series
# then errs ~TOL^6, below double precision (Numerical Recipes' choices for doubles).
RF_TOL, RJ_TOL = 0.0025, 0.0015
# Each duplication divides the spread of the arguments by ~4, so this many reach RF_TOL from
# a spread of 1e300; a NaN argument never converges and stops here, still NaN.
MAX_DUPLICATIONS = 600


@intrinsic
def _agm_ratios(typingctx):
    """AGM_MAX_STEPS doubles in the caller's stack frame: no allocation per call."""
    def codegen(context, builder, sig, args):
        """Allocate the doubles once, in the function's entry block."""
        count = context.get_constant(types.intp, AGM_MAX_STEPS)
        return cgutils.alloca_once(builder, context.get_value_type(types.double), size=count)
    return types.CPointer(types.double)(), codegen


@kernel
def sn_cn(u, mc):
    """Jacobi ``sn`` and ``cn`` of ``u`` at parameter ``m = 1 - mc``, from 0 < ``mc`` <= 1.

    Descending Gauss transformation (Abramowitz and Stegun 16.4): the arithmetic-geometric
    mean of (1, sqrt(mc)) gives a_n and c_n = (a_{n-1} - b_{n-1}) / 2 until c_N vanishes;
    then phi_N = 2^N a_N u and ``phi_{n-1} = (phi_n + arcsin(c_n / a_n sin phi_n)) / 2``
    down to the amplitude phi_0: sn = sin phi_0, cn = cos phi_0.
    """
    ratios = carray(_agm_ratios(), AGM_MAX_STEPS)
    a, b = 1.0, math.sqrt(mc)
    steps = 0
    for _ in range(AGM_MAX_STEPS):
        c = 0.5 * (a - b)
        a, b = 0.5 * (a + b), math.sqrt(a * b)
        ratios[steps] = c / a
        steps += 1
        if ratios[steps - 1] < AGM_TOL:
            break
    phi = 2.0 ** steps * a * u
    for n in range(steps - 1, -1, -1):
        phi = 0.5 * (phi + math.asin(ratios[n] * math.sin(phi)))
    return math.sin(phi), math.cos(phi)


@helper
def ellipkm1(mc):
    """Complete elliptic integral ``K`` at parameter ``m = 1 - mc``, from ``mc``."""
    return _ellipkm1(mc, 0)


@kernel
def elliprf(x, y, z):
    """Carlson's symmetric integral ``R_F(x, y, z)``, x, y, z >= 0, at most one zero."""
    if (x == 0.0) + (y == 0.0) + (z == 0.0) > 1:
        return math.inf
    for _ in range(MAX_DUPLICATIONS):
        sx, sy, sz = math.sqrt(x), math.sqrt(y), math.sqrt(z)
        lam = sx * (sy + sz) + sy * sz
        x, y, z = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam)
        mean = (x + y + z) / 3.0
        if max(abs(mean - x), max(abs(mean - y), abs(mean - z))) <= RF_TOL * mean:
            break
    inverse = 1.0 / mean
    dx, dy, dz = (mean - x) * inverse, (mean - y) * inverse, (mean - z) * inverse
    e2 = dx * dy - dz * dz
    e3 = dx * dy * dz
    return (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / math.sqrt(mean)


# Below this |e|, R_C(1, 1 + e) is its Maclaurin series to five terms: the sixth is ~e^5 / 11,
# below double precision. A duplication divides e by ~64, so all but the first one or two
# terms of R_J's sum take the series rather than an arctangent.
RC_SERIES = 1e-3


@helper
def _elliprc_one(e, sp, p, lam, d):
    """Carlson's ``R_C(1, 1 + e)``, e > -1: ``atan(sqrt e) / sqrt e`` or its atanh twin.

    ``sp``, ``p``, ``lam`` and ``d`` are sqrt p, p, lambda and d_m of R_J's same step. Where
    ``e`` nears -1 (p far below x, y and z) the sum ``1 + e`` would cancel; it is
    ``2 sqrt(p) (p + lambda) / d``, since ``d^2 + 4^(-3m) delta = 2 d sqrt(p) (p + lambda)``,
    and the inverse hyperbolic tangent is taken as ``log((1 + r) / sqrt(1 + e)) / r``.
    """
    if abs(e) < RC_SERIES:
        return 1.0 - e * (1.0 / 3.0 - e * (0.2 - e * (1.0 / 7.0 - e / 9.0)))
    root = math.sqrt(abs(e))
    if e > 0.0:
        return math.atan(root) / root
    if e > -0.5:
        return math.atanh(root) / root
    return math.log((1.0 + root) / math.sqrt(2.0 * sp * (p + lam) / d)) / root


@kernel
def elliprj(x, y, z, p):
    """Evaluate Carlson's symmetric integral ``R_J(x, y, z, p)``.

    Defined for x, y, z >= 0 with at most one of them zero, and p > 0. Carlson's 1995
    duplication: the term each step adds is ``R_C(1, 1 + e_m) / d_m``, with
    ``d_m = (sqrt p + sqrt x)(sqrt p + sqrt y)(sqrt p + sqrt z)`` and
    ``e_m = 4^(-3m) (p - x)(p - y)(p - z) / d_m^2``, a closed form where the 1979 algorithm
    ran a duplication of R_C's own inside every step.
    """
    if (x == 0.0) + (y == 0.0) + (z == 0.0) > 1:
        return math.inf
    delta = (p - x) * (p - y) * (p - z)
    total, factor = 0.0, 1.0
    for _ in range(MAX_DUPLICATIONS):
        sx, sy, sz, sp = math.sqrt(x), math.sqrt(y), math.sqrt(z), math.sqrt(p)
        lam = sx * (sy + sz) + sy * sz
        d = (sp + sx) * (sp + sy) * (sp + sz)
        e = factor * factor * factor * delta / (d * d)
        total += factor * _elliprc_one(e, sp, p, lam, d) / d
        factor *= 0.25
        x, y, z, p = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam), 0.25 * (p + lam)
        mean = 0.2 * (x + y + z + p + p)
        if (max(max(abs(mean - x), abs(mean - y)), max(abs(mean - z), abs(mean - p)))
                <= RJ_TOL * mean):
            break
    inverse = 1.0 / mean
    dx, dy = (mean - x) * inverse, (mean - y) * inverse
    dz, dp = (mean - z) * inverse, (mean - p) * inverse
    ea = dx * (dy + dz) + dy * dz
    eb = dx * dy * dz
    ec = dp * dp
    ed = ea - 3.0 * ec
    ee = eb + 2.0 * dp * (ea - ec)
    series = (1.0 + ed * (-3.0 / 14.0 + 9.0 / 88.0 * ed - 9.0 / 52.0 * ee)
              + eb * (1.0 / 6.0 + dp * (-3.0 / 11.0 + dp * 3.0 / 26.0))
              + dp * ea * (1.0 / 3.0 - dp * 3.0 / 22.0) - dp * ec / 3.0)
    return 6.0 * total + factor * series / (mean * math.sqrt(mean))
