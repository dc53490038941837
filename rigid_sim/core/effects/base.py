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
:func:`accumulate` compiles one loop over the tuple of parameters a scene lists, so numba
builds a kernel specialised to exactly that set: an unlisted effect is not in the compiled
code at all. When every listed effect acts per body (:func:`acts_per_body`), an integrator
may instead take each body through a whole step in registers with :func:`body_wrench`.
"""
import numpy as np
from numba import literal_unroll, njit
from numba.extending import overload

from rigid_sim.core import kinematics as kin

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

    Parameters
    ----------
    bodies : RigidBodies
    """

    velocity_dependent = False   # its wrench depends on the momenta (dampers)

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


def _apply_one(parameters, y, time, model, force, torque):
    """Typing stub: replaced, per parameter class, by that effect's kernel."""


@overload(_apply_one)
def _apply_one_overload(parameters, y, time, model, force, torque):
    if parameters.instance_class in KERNELS:
        kernel = KERNELS[parameters.instance_class]

        def apply(parameters, y, time, model, force, torque):
            """Call the registered kernel."""
            kernel(parameters, y, time, model, force, torque)
        return apply
    body_kernel = BODY_KERNELS[parameters.instance_class]

    def apply_per_body(parameters, y, time, model, force, torque):
        """Call the kernel of one body for every body, adding into the sums."""
        for i in range(y.shape[0]):
            f, t = body_kernel(parameters, i, kin.vector(y, i, 0), kin.orientation(y, i),
                               kin.vector(y, i, 7), kin.vector(y, i, 10), time, model)
            for k in range(3):
                force[i, k] += f[k]
                torque[i, k] += t[k]
    return apply_per_body


def _body_one(parameters, i, x, q, p, big_l, time, model):
    """Typing stub: replaced, per parameter class, by that effect's kernel of one body."""


@overload(_body_one, inline='always')
def _body_one_overload(parameters, i, x, q, p, big_l, time, model):
    kernel = BODY_KERNELS[parameters.instance_class]

    def apply(parameters, i, x, q, p, big_l, time, model):
        """Call the registered kernel."""
        return kernel(parameters, i, x, q, p, big_l, time, model)
    return apply


@njit(cache=True)
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
    force[:, :] = 0.0
    torque[:, :] = 0.0
    for parameters in literal_unroll(effects):
        _apply_one(parameters, y, time, model, force, torque)


def body_wrench(effects, i, x, q, p, big_l, time, model):
    """Net world force and torque (3-tuples) of ``effects`` on body ``i`` at its own state.

    Compiled code only. Every parameters object in ``effects`` must have a kernel of one
    body (:func:`acts_per_body`); the arguments are those of such a kernel. The terms add in
    the order :func:`accumulate` adds them, so both give the same sums to the last bit.
    """


# Inlined into the caller's IR, as is _body_one: as separate functions, every nested call
# passed and reference-counted the effects' arrays, for every body and stage, which made
# the sum some 70 times slower (docs/performance.md, "A body at a time").
@overload(body_wrench, inline='always')
def _body_wrench_overload(effects, i, x, q, p, big_l, time, model):
    def total(effects, i, x, q, p, big_l, time, model):
        """Fold the effects' terms onto zero."""
        zero = (0.0, 0.0, 0.0)
        return _fold(effects, zero, zero, i, x, q, p, big_l, time, model)
    return total


def _fold(effects, force, torque, i, x, q, p, big_l, time, model):
    """Typing stub: ``force`` and ``torque`` plus the terms of ``effects``, first to last."""


@overload(_fold, inline='always')
def _fold_overload(effects, force, torque, i, x, q, p, big_l, time, model):
    if len(effects) == 0:
        def done(effects, force, torque, i, x, q, p, big_l, time, model):
            """Nothing left to add."""
            return force, torque
        return done

    def add_first(effects, force, torque, i, x, q, p, big_l, time, model):
        """Add the first effect's term, then fold the rest (a tuple type of its own)."""
        f, t = _body_one(effects[0], i, x, q, p, big_l, time, model)
        return _fold(effects[1:], kin.add(force, f), kin.add(torque, t), i, x, q, p, big_l,
                     time, model)
    return add_first
