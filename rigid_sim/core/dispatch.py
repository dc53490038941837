# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Calling compiled kernels without paying numba's argument dispatch on every call."""
from concurrent.futures import ThreadPoolExecutor
import functools
import os

from numba import config, typeof
from numba.core.typing.typeof import Purpose


class CompiledCall(functools.partial):
    """A compiled kernel called again and again with arguments of the same types.

    numba's dispatcher resolves the type of every argument on every call (microseconds for
    the nested tuples of a scene's parameters, most of a one-body step). The types of an
    integrator's arguments never change, so the specialisation found on the first call is
    called directly afterwards.

    A ``functools.partial`` whose function is then that specialisation's entry point, set
    through the state partial keeps for pickling: its call, in C, reaches the entry point
    with no Python frame in between (a method forwarding ``*args`` cost 90 ns a call, a
    fifth of the Python work of a one-body guarded step).
    """

    def __new__(cls, dispatcher):
        call = super().__new__(cls, cls._first_call)   # partial wants a callable: replaced
        call._dispatcher = dispatcher
        call._call(call._first_call)
        return call

    def _call(self, function):
        """Make calls of this object calls of ``function``, with no argument bound."""
        self.__setstate__((function, (), None, self.__dict__))

    def _first_call(self, *args):
        result = self._dispatcher(*args)   # compiles, or loads from the disk cache
        types = tuple(typeof(arg, Purpose.argument) for arg in args)
        self._call(self._dispatcher.overloads[types].entry_point)
        return result


# Bodies from which a kernel that steps each body alone runs on several threads. With a
# second core free, World.step on 2 threads: rk4 0.65x at 1000 bodies, 1.4x at 1e4, 1.7x at
# 1e5; exact_split 1.5x, 1.8x, 1.85x. With none free: 0.83x at 1000, 0.93-0.98x at 1e4,
# 1.0x at 1e5 (docs/performance.md, "Bodies on threads").
THREADED_BODIES = 10000
# For the splittings, whose body-step is 5-10 times the Runge-Kutta one (the free flow, and
# DLM's comparison with it): with a core free exact_split gains 1.4-1.5x at 1000 bodies
# (docs/performance.md), where a node at 1 kHz has 1 ms for the whole tick.
HEAVY_THREADED_BODIES = 1000


@functools.lru_cache(maxsize=None)
def _pool(workers, process):
    """Return the threads that run ranges of bodies beside the caller's: one pool a process.

    A forked child has none of its parent's threads, so it makes its own (``process``: its
    id).
    """
    return ThreadPoolExecutor(workers, thread_name_prefix='rigid_sim_bodies')


class BodyThreads:
    """A kernel stepping each body alone, on contiguous ranges of the bodies at once.

    ``dispatcher`` compiles the kernel: ``work`` is the range ``(first, end)`` it steps, the
    other arguments those of the one-call kernel, and it releases the GIL (``nogil``). Bodies
    are independent, so the ranges give the bits one call over all would. The kernel returns
    a failure code and the largest error estimate: the codes combine as one pass in body
    order would (the earliest bad substep, the first body on ties), the estimates by their
    largest.
    """

    def __init__(self, dispatcher, count, threads):
        edges = [count * k // threads for k in range(threads + 1)]
        self._ranges = [(edges[k], edges[k + 1]) for k in range(threads)]
        self._call = CompiledCall(dispatcher)
        self._threads = threads

    def __call__(self, y, work, *rest):
        """Call the kernel on each range (``work``, the one-call kernel's, is not used)."""
        pool = _pool(self._threads - 1, os.getpid())
        others = [pool.submit(self._call, y, bodies, *rest)
                  for bodies in self._ranges[1:]]
        results = [self._call(y, self._ranges[0], *rest)] + [other.result() for other in others]
        failed = [code for code, _ in results if code != 0]
        return (min(failed, key=abs) if failed else 0), max(largest for _, largest in results)


def across_threads(call, threaded, count, heavy=False):
    """``call`` for ``count`` bodies, or where threads pay :class:`BodyThreads` of ``threaded``.

    ``heavy``: a body-step costs several times a Runge-Kutta one, so threads pay from
    :data:`HEAVY_THREADED_BODIES` bodies on.

    The threads are as many as numba's (``NUMBA_NUM_THREADS``, by default the cores).
    """
    threads = config.NUMBA_NUM_THREADS
    if count < (HEAVY_THREADED_BODIES if heavy else THREADED_BODIES) or threads < 2:
        return call
    return BodyThreads(threaded, count, threads)
