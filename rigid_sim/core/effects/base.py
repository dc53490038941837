# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The contract every effect keeps, and the compiled sum over a scene's effects.

An effect holds its parameters as arrays in a ``typing.NamedTuple`` of its own class
(``parameters``) and registers a compiled kernel for that class with :func:`kernel_for`::

    kernel(parameters, y, time, model, force, torque)

adds its world-axes forces and torques about the centres of mass into ``force`` and
``torque`` (N, 3) at the packed state ``y`` (N, 13) = [x, q, P, L] and ``time`` (s);
``model`` is the :class:`~rigid_sim.core.state.Model` of the bodies. :func:`accumulate`
compiles one loop over the tuple of parameters a scene lists, so numba builds a kernel
specialised to exactly that set: an unlisted effect is not in the compiled code at all.
"""
import numpy as np
from numba import literal_unroll, njit
from numba.extending import overload

KERNELS = {}   # NamedTuple class of an effect's parameters -> its compiled kernel


def kernel_for(parameter_class):
    """Register the decorated compiled kernel as the one for ``parameter_class``."""
    def register(kernel):
        """Record ``kernel`` and hand it back unchanged."""
        KERNELS[parameter_class] = kernel
        return kernel
    return register


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
    kernel = KERNELS[parameters.instance_class]

    def apply(parameters, y, time, model, force, torque):
        """Call the registered kernel."""
        kernel(parameters, y, time, model, force, torque)
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
