# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The contract every effect keeps, and the compiled sum over a scene's effects.

An effect holds its parameters as arrays in a ``typing.NamedTuple`` of its own class
(``parameters``) and registers one compiled kernel for that class. An effect whose wrench on
a body depends only on that body's own state (gravity, damping, the held wrenches) registers
it with :func:`body_kernel_for`::

    kernel(parameters, i, x, q, p, big_l, time, model) -> (force, torque)

returning body ``i``'s world-axes force and torque about its centre of mass (3-tuples) at its
position ``x``, quaternion ``q``, momentum ``p`` and world-axes angular momentum ``big_l``
(tuples) and ``time`` (s). An effect that couples bodies (springs between two bodies)
registers with :func:`kernel_for`::

    kernel(parameters, y, time, model, force, torque)

adding its forces and torques into ``force`` and ``torque`` (N, 3) at the packed state ``y``
(N, 13) = [x, q, P, L]. ``model`` is the :class:`~rigid_sim.core.state.Model` of the bodies.
:func:`accumulate` sums them in one function written out for the tuple of parameter types
a scene lists, so numba builds a kernel specialised to exactly that set: an unlisted effect
is not in the compiled code at all. When every listed effect acts per body
(:func:`acts_per_body`), an integrator may instead take each body through a whole step in
registers with :func:`body_wrench`.
"""
import itertools

import numpy as np
from numba.extending import overload

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import kernel

# NamedTuple class of an effect's parameters -> its compiled kernel: one that couples
# bodies (the whole state in, the (N, 3) sums out) or one of a single body.
KERNELS = {}
BODY_KERNELS = {}


def kernel_for(parameter_class):
    """Register the decorated compiled kernel of all bodies as the one for ``parameter_class``."""
    def register(kernel):
        """Record ``kernel`` and hand it back unchanged."""
        KERNELS[parameter_class] = kernel
        return kernel
    return register


def body_kernel_for(parameter_class):
    """Register the decorated compiled kernel of one body as the one for ``parameter_class``."""
    def register(kernel):
        """Record ``kernel`` and hand it back unchanged."""
        BODY_KERNELS[parameter_class] = kernel
        return kernel
    return register


def acts_per_body(effects):
    """Whether every parameters object in ``effects`` has a kernel of one body (none couples)."""
    return all(type(parameters) in BODY_KERNELS for parameters in effects)


class Effect:
    """Base class: what an effect declares, with the defaults of a passive external force.

    A subclass declares, as class attributes, its scene key ``name`` (under ``effects:``),
    ``scene_fields``, the checker of its scene entry (built from
    :mod:`rigid_sim.core.scene_fields`), and ``parts``, the NamedTuple classes its
    ``parameters`` may be, each with a compiled kernel registered for it. The registry
    (``rigid_sim.core.effects.REGISTRY``) refuses a class that leaves one out.

    Parameters
    ----------
    bodies : RigidBodies
    """

    name = None                  # its key under the scene's effects:
    scene_fields = None          # checker(value, key) -> settings, or raises Mistake
    parts = ()                   # NamedTuple classes of its parameters, each with a kernel
    velocity_dependent = False   # its wrench depends on the momenta (dampers)

    @classmethod
    def resolve(cls, settings, key, bodies):
        """Return the checked ``settings`` of a scene whose bodies are ``bodies``; None: empty.

        For settings that name bodies (a spring's ends): ``bodies`` are the scene's BodySpecs.
        Raises :class:`~rigid_sim.core.scene_fields.Mistake` at ``key`` or below it. None
        means the entry lists nothing to build.
        """
        return settings

    @classmethod
    def from_settings(cls, bodies, settings):
        """Return the effect on ``bodies`` (RigidBodies) of resolved scene ``settings``."""
        return cls(bodies, **settings)

    def __init__(self, bodies):
        # (N,) bool: bodies it may torque; the rest move by the exact free flow in splittings.
        self.torqued = np.zeros(bodies.count, dtype=bool)

    @property
    def parameters(self):
        """Return the NamedTuple of arrays the effect's registered kernel reads."""
        raise NotImplementedError

    def potential_energy(self, snapshot):
        """Return the energy the effect stores at ``snapshot``, J (0: dissipative or external)."""
        return 0.0

    def fastest_rate(self):
        """Fastest frequency or decay rate it imposes, 1/s: a step must resolve it."""
        return 0.0


@kernel
def accumulate(effects, y, time, model, force, torque):
    """Write the net wrench of every effect in ``effects`` into ``force`` and ``torque``.

    Parameters
    ----------
    effects : tuple of NamedTuple
        The effects' parameters; never empty (the world's inputs come last).
    y : (N, 13) float
        Packed state [x, q, P, L], world frame.
    time : float
        Simulated time, s.
    model : Model
        The bodies' static arrays.
    force : (N, 3) float
        Overwritten with the net force on each body, N, world axes.
    torque : (N, 3) float
        Overwritten with the net torque about each centre of mass, N m, world axes.
    """
    _sum_all(effects, y, time, model, force, torque)


def _sum_all(effects, y, time, model, force, torque):
    """Typing stub: :func:`accumulate`'s sum, written out for the types in ``effects``."""


def body_wrench(effects, i, x, q, p, big_l, time, model):
    """Net world force and torque (3-tuples) of ``effects`` on body ``i`` at its own state.

    Compiled code only. Every parameters object in ``effects`` must have a kernel of one
    body (:func:`acts_per_body`); the arguments are those of such a kernel. The terms add in
    the order :func:`accumulate` adds them, so both give the same sums to the last bit.
    """


# The sums over a scene's effects are written out as Python source for its tuple of
# parameter types, one statement per effect, and compiled as one function: numba types it
# once. A recursion over the tuple (an overload per remaining tuple type) or literal_unroll
# made numba type the same code again and again, which took most of a cold start's
# compile time (docs/performance.md, "Compile cost").
def _written_out(name, arguments, lines, effects):
    """Return the function ``name(effects, arguments)`` whose body is the source ``lines``.

    The lines are indented one level inside it; its globals are ``kin`` (the kinematics
    module) and ``kernel<k>``, the kernel registered for ``effects[k]``'s class.
    """
    names = {'kin': kin}
    for k, parameters in enumerate(effects):
        kind = parameters.instance_class
        names[f'kernel{k}'] = KERNELS[kind] if kind in KERNELS else BODY_KERNELS[kind]
    source = [f'def {name}(effects, {arguments}):'] + ['    ' + line for line in lines]
    exec('\n'.join(source), names)   # noqa: S102  source made above, from names only
    return names[name]


def _body_terms(indices, force, torque):
    """Lines adding the terms of the body kernels ``effects[k]``, k in ``indices``.

    The running sums are the tuples named ``force`` and ``torque``; body ``i``'s state is
    ``x, q, p, big_l``.
    """
    lines = []
    for k in indices:
        lines += [f'f, t = kernel{k}(effects[{k}], i, x, q, p, big_l, time, model)',
                  f'{force}, {torque} = kin.add({force}, f), kin.add({torque}, t)']
    return lines


# Inlined into the caller's IR: as a function, every call per body and stage passed and
# reference-counted the effects' arrays, which made the sum some 70 times slower
# (docs/performance.md, "A body at a time").
@overload(body_wrench, inline='always')
def _body_wrench_overload(effects, i, x, q, p, big_l, time, model):
    lines = (['force = torque = (0.0, 0.0, 0.0)']
             + _body_terms(range(len(effects)), 'force', 'torque') + ['return force, torque'])
    return _written_out('body_wrench_sum', 'i, x, q, p, big_l, time, model', lines, effects)


@overload(_sum_all)
def _sum_all_overload(effects, y, time, model, force, torque):
    lines = ['force[:, :] = 0.0', 'torque[:, :] = 0.0']
    coupling = [parameters.instance_class in KERNELS for parameters in effects]
    for couples, run in itertools.groupby(range(len(effects)), coupling.__getitem__):
        if couples:
            lines += [f'kernel{k}(effects[{k}], y, time, model, force, torque)' for k in run]
            continue
        # Consecutive per-body effects in one pass: each adds into a body's sums in turn.
        terms = _body_terms(run, 'body_force', 'body_torque')
        lines += ['for i in range(y.shape[0]):',
                  '    x, q, p, big_l = kin.body_state(y, i)',
                  '    body_force = kin.vector(force, i, 0)',
                  '    body_torque = kin.vector(torque, i, 0)',
                  *['    ' + line for line in terms],
                  '    kin.store(force, i, 0, body_force)',
                  '    kin.store(torque, i, 0, body_torque)']
    return _written_out('sum_all', 'y, time, model, force, torque', lines, effects)
