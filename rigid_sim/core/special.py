# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""scipy's elliptic functions inside compiled code: ``ellipj``, ``ellipkm1``, ``elliprf``,
``elliprj`` of ``scipy.special.cython_special``.

Each C function is registered with LLVM under a symbol of its own and declared to numba as
an external function of that name, so compiled code refers to it by name, not by an
address: that keeps ``cache=True`` working (an address is valid only in the process that
took it). The registration runs at import, before any cached kernel is loaded.
"""
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
    'rigid_sim_elliprf': ('__pyx_fuse_1elliprf',
                          types.double(types.double, types.double, types.double, types.intc)),
    'rigid_sim_elliprj': ('__pyx_fuse_1elliprj',
                          types.double(types.double, types.double, types.double, types.double,
                                       types.intc)),
}
for _symbol, (_export, _) in _EXPORTS.items():
    llvm.add_symbol(_symbol, get_cython_function_address(_MODULE, _export))
_ellipj = types.ExternalFunction('rigid_sim_ellipj', _EXPORTS['rigid_sim_ellipj'][1])
_ellipkm1 = types.ExternalFunction('rigid_sim_ellipkm1', _EXPORTS['rigid_sim_ellipkm1'][1])
_elliprf = types.ExternalFunction('rigid_sim_elliprf', _EXPORTS['rigid_sim_elliprf'][1])
_elliprj = types.ExternalFunction('rigid_sim_elliprj', _EXPORTS['rigid_sim_elliprj'][1])


@intrinsic
def _four_doubles(typingctx):
    """Four doubles on the stack, as pointers: ``ellipj``'s outputs without an allocation."""
    signature = types.UniTuple(_DOUBLE_POINTER, 4)()

    def codegen(context, builder, sig, args):
        double = context.get_value_type(types.double)
        pointers = [cgutils.alloca_once(builder, double) for _ in range(4)]
        return context.make_tuple(builder, sig.return_type, pointers)
    return signature, codegen


@intrinsic
def _load(typingctx, pointer):
    """The double ``pointer`` points to."""
    def codegen(context, builder, sig, args):
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
    """Carlson's symmetric integral ``R_F(x, y, z)``."""
    return _elliprf(x, y, z, 0)


@njit(cache=True)
def elliprj(x, y, z, p):
    """Carlson's symmetric integral ``R_J(x, y, z, p)``."""
    return _elliprj(x, y, z, p, 0)
