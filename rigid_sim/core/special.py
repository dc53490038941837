# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Elliptic functions inside compiled code: scipy's, and Carlson's R_F and R_J.

``ellipj`` and ``ellipkm1`` are those of ``scipy.special.cython_special``. Carlson's
symmetric integrals are written out here by his duplication method (B. C. Carlson,
Numerical Algorithms 10, 1995, as in Numerical Recipes 3rd ed., 6.12): the free flow calls
three per body and drift, and scipy's cost more for the same double-precision result
(docs/performance.md has the timings); scipy's stay the reference the tests compare with.

Each C function is registered with LLVM under a symbol of its own and declared to numba as
an external function of that name, so compiled code refers to it by name, not by an
address: that keeps ``cache=True`` working (an address is valid only in the process that
took it). The registration runs at import, before any cached kernel is loaded.
"""
import math

import llvmlite.binding as llvm
from numba import njit, types
from numba.core import cgutils
from numba.extending import get_cython_function_address, intrinsic

_MODULE = 'scipy.special.cython_special'
_DOUBLE_POINTER = types.CPointer(types.double)
# Symbol, cython_special export, signature (the trailing int: Cython's skip-dispatch flag).
_EXPORTS = {
    'rigid_sim_ellipj': ('ellipj', types.void(types.double, types.double, _DOUBLE_POINTER,
                                              _DOUBLE_POINTER, _DOUBLE_POINTER,
                                              _DOUBLE_POINTER)),
    'rigid_sim_ellipkm1': ('ellipkm1', types.double(types.double, types.intc)),
}
for _symbol, (_export, _) in _EXPORTS.items():
    llvm.add_symbol(_symbol, get_cython_function_address(_MODULE, _export))
_ellipj = types.ExternalFunction('rigid_sim_ellipj', _EXPORTS['rigid_sim_ellipj'][1])
_ellipkm1 = types.ExternalFunction('rigid_sim_ellipkm1', _EXPORTS['rigid_sim_ellipkm1'][1])
# Duplication stops when every argument is within this of their mean: the truncated series
# then errs ~TOL^6, below double precision (Numerical Recipes' choices for doubles).
RF_TOL, RJ_TOL, RC_TOL = 0.0025, 0.0015, 0.0012
# Each duplication divides the spread of the arguments by ~4, so this many reach RF_TOL from
# a spread of 1e300; a NaN argument never converges and stops here, still NaN.
MAX_DUPLICATIONS = 600


@intrinsic
def _four_doubles(typingctx):
    """Four doubles on the stack, as pointers: ``ellipj``'s outputs without an allocation."""
    signature = types.UniTuple(_DOUBLE_POINTER, 4)()

    def codegen(context, builder, sig, args):
        """Allocate the four doubles in the caller's stack frame."""
        double = context.get_value_type(types.double)
        pointers = [cgutils.alloca_once(builder, double) for _ in range(4)]
        return context.make_tuple(builder, sig.return_type, pointers)
    return signature, codegen


@intrinsic
def _load(typingctx, pointer):
    """Load the double that ``pointer`` points to."""
    def codegen(context, builder, sig, args):
        """Load through the pointer."""
        return builder.load(args[0])
    return types.double(pointer), codegen


@njit(cache=True)
def ellipj(u, m):
    """Jacobi ``sn``, ``cn``, ``dn`` of ``u`` at parameter ``m = k^2``."""
    sn, cn, dn, amplitude = _four_doubles()
    _ellipj(u, m, sn, cn, dn, amplitude)
    return _load(sn), _load(cn), _load(dn)


@njit(cache=True)
def ellipkm1(mc):
    """Complete elliptic integral ``K`` at parameter ``m = 1 - mc``, from ``mc``."""
    return _ellipkm1(mc, 0)


@njit(cache=True)
def elliprf(x, y, z):
    """Carlson's symmetric integral ``R_F(x, y, z)``, x, y, z >= 0, at most one zero."""
    if (x == 0.0) + (y == 0.0) + (z == 0.0) > 1:
        return math.inf
    for _ in range(MAX_DUPLICATIONS):
        sx, sy, sz = math.sqrt(x), math.sqrt(y), math.sqrt(z)
        lam = sx * (sy + sz) + sy * sz
        x, y, z = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam)
        mean = (x + y + z) / 3.0
        dx, dy, dz = (mean - x) / mean, (mean - y) / mean, (mean - z) / mean
        if max(abs(dx), max(abs(dy), abs(dz))) <= RF_TOL:
            break
    e2 = dx * dy - dz * dz
    e3 = dx * dy * dz
    return (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / math.sqrt(mean)


@njit(cache=True)
def _elliprc(x, y):
    """Carlson's degenerate integral ``R_C(x, y)`` for x >= 0, y > 0."""
    for _ in range(MAX_DUPLICATIONS):
        lam = 2.0 * math.sqrt(x) * math.sqrt(y) + y
        x, y = 0.25 * (x + lam), 0.25 * (y + lam)
        mean = (x + y + y) / 3.0
        s = (y - mean) / mean
        if abs(s) <= RC_TOL:
            break
    return (1.0 + s * s * (0.3 + s * (1.0 / 7.0 + s * (0.375 + s * 9.0 / 22.0)))) \
        / math.sqrt(mean)


@njit(cache=True)
def elliprj(x, y, z, p):
    """Evaluate Carlson's symmetric integral ``R_J(x, y, z, p)``.

    Defined for x, y, z >= 0 with at most one of them zero, and p > 0.
    """
    if (x == 0.0) + (y == 0.0) + (z == 0.0) > 1:
        return math.inf
    total, factor = 0.0, 1.0
    for _ in range(MAX_DUPLICATIONS):
        sx, sy, sz = math.sqrt(x), math.sqrt(y), math.sqrt(z)
        lam = sx * (sy + sz) + sy * sz
        alpha = (p * (sx + sy + sz) + sx * sy * sz) ** 2
        total += factor * _elliprc(alpha, p * (p + lam) ** 2)
        factor *= 0.25
        x, y, z, p = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam), 0.25 * (p + lam)
        mean = 0.2 * (x + y + z + p + p)
        dx, dy = (mean - x) / mean, (mean - y) / mean
        dz, dp = (mean - z) / mean, (mean - p) / mean
        if max(max(abs(dx), abs(dy)), max(abs(dz), abs(dp))) <= RJ_TOL:
            break
    ea = dx * (dy + dz) + dy * dz
    eb = dx * dy * dz
    ec = dp * dp
    ed = ea - 3.0 * ec
    ee = eb + 2.0 * dp * (ea - ec)
    series = (1.0 + ed * (-3.0 / 14.0 + 9.0 / 88.0 * ed - 9.0 / 52.0 * ee)
              + eb * (1.0 / 6.0 + dp * (-3.0 / 11.0 + dp * 3.0 / 26.0))
              + dp * ea * (1.0 / 3.0 - dp * 3.0 / 22.0) - dp * ec / 3.0)
    return 3.0 * total + factor * series / (mean * math.sqrt(mean))
