# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Calling compiled kernels without paying numba's argument dispatch on every call."""
from numba import typeof
from numba.core.typing.typeof import Purpose


class CompiledCall:
    """A compiled kernel called again and again with arguments of the same types.

    numba's dispatcher resolves the type of every argument on every call (microseconds for
    the nested tuples of a scene's parameters, most of a one-body step). The types of an
    integrator's arguments never change, so the specialisation found on the first call is
    called directly afterwards.
    """

    def __init__(self, dispatcher):
        self._dispatcher = dispatcher
        self._entry = None

    def __call__(self, *args):
        if self._entry is not None:
            return self._entry(*args)
        result = self._dispatcher(*args)   # compiles, or loads from the disk cache
        types = tuple(typeof(arg, Purpose.argument) for arg in args)
        self._entry = self._dispatcher.overloads[types].entry_point
        return result
