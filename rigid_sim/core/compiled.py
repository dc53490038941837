# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The two kinds of compiled function in the core, both numba ``njit`` with ``cache=True``.

A :func:`kernel` is called from Python (an integrator's step, a test): numba gives it a
wrapper that converts Python arguments. A :func:`helper` is called only by other compiled
functions, so it gets no wrapper. numba would otherwise build two wrappers for every small
function (one for Python callers, one for C callers) and optimise and emit machine code for
both, about a quarter of the time a first start spends compiling (docs/performance.md,
"Compile cost"); callers within compiled code never use them. A helper called from Python
raises TypeError, as there is no wrapper to call.

:func:`inlined` makes a copy of a helper that numba inlines into its callers, for the few
kernels that need it without making every other caller pay for it.
"""
from types import FunctionType, ModuleType

from numba import njit, types
from numba.core.registry import CPUDispatcher


class CompiledOnly(CPUDispatcher):
    """numba's dispatcher of a function compiled without a Python wrapper: not for Python."""

    def __call__(self, *args, **kwargs):
        raise TypeError(f'{self.py_func.__module__}.{self.py_func.__qualname__} is compiled '
                        'for compiled callers only (a helper): call a kernel from Python')

    def get_call_template(self, args, kws):
        """Type a call from compiled code by the arguments' types, never by constant values.

        numba would otherwise compile a helper once per constant it is called with
        (``kin.vector(y, i, 0)`` and ``kin.vector(y, i, 7)``: two specialisations).
        """
        return super().get_call_template(tuple(types.unliteral(a) for a in args),
                                         {name: types.unliteral(a) for name, a in kws.items()})


def kernel(function=None, **options):
    """Compile ``function`` for callers in Python and in compiled code (``njit`` options)."""
    decorate = njit(cache=True, **options)
    return decorate if function is None else decorate(function)


def helper(function=None, **options):
    """Compile ``function`` for compiled callers only: no Python or C wrapper (``njit`` options).

    Usable as ``@helper`` or ``@helper(inline='always')``.
    """
    def decorate(function):
        """Return the dispatcher of ``function``, made uncallable from Python."""
        compiled = njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True,
                        **options)(function)
        if isinstance(compiled, CPUDispatcher):   # not when NUMBA_DISABLE_JIT is set
            compiled.__class__ = CompiledOnly
        return compiled
    return decorate if function is None else decorate(function)


def inlined(function, **names):
    """Return a copy of the helper ``function`` that numba inlines where it is called.

    numba inlines a function by copying its IR into every call and typing it again there,
    which multiplies the compile time of a caller that calls it often; calls left to LLVM
    cost nothing to compile but may stay calls, which a loop meant to vectorise cannot hold
    (docs/performance.md, "Bodies in lanes"). So the helpers stay as they are for every
    kernel, and a kernel whose loops need them inlined calls copies made here: the same
    code (so the same arithmetic), compiled into the caller with the caller's options.
    ``names`` replace globals the copy reads, such as a module by :func:`inlined_module`,
    so that what the copy calls in turn is inlined as well.
    """
    original = function.py_func
    copy = FunctionType(original.__code__, {**original.__globals__, **names},
                        original.__name__, original.__defaults__, original.__closure__)
    copy.__qualname__ = original.__qualname__
    return helper(copy, inline='always')


def inlined_module(module, *names):
    """Return a module with ``module``'s attributes, its helpers ``names`` :func:`inlined`."""
    copy = ModuleType(module.__name__, module.__doc__)
    copy.__dict__.update(vars(module))
    copy.__dict__.update({name: inlined(getattr(module, name)) for name in names})
    return copy
