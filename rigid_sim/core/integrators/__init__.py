# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Integrators behind one interface (see ``base.Integrator``), chosen by name."""
from rigid_sim.core.integrators.adaptive import Dopri5
from rigid_sim.core.integrators.runge_kutta import RK4, RK4World, ExplicitEuler
from rigid_sim.core.integrators.splitting import DLM, DLM4, ExactSplit, ExactSplit4
from rigid_sim.core.integrators.symplectic_euler import SemiImplicitEuler
from rigid_sim.core.safeguards import StepBound

# The node's default; chosen from the accuracy benchmark (docs/accuracy.md).
DEFAULT_INTEGRATOR = 'exact_split'


def registry(*classes):
    """Map each integrator class's ``name`` to it.

    Raises TypeError for a class that declares no step bound or no estimate order (the base
    class has neither): the guard splits steps by the one and error control by the other,
    and a method that forgot either would run unguarded.
    """
    for cls in classes:
        if not isinstance(getattr(cls, 'bound', None), StepBound):
            raise TypeError(f'integrator {cls.__name__} declares no step bound: give it the '
                            'class attribute bound, a safeguards.StepBound '
                            '(safeguards.UNBOUNDED where none applies)')
        if not isinstance(getattr(cls, 'estimate_order', None), int):
            raise TypeError(f'integrator {cls.__name__} declares no estimate_order: the power '
                            'of h, less one, at which its error estimate per step shrinks')
    return {cls.name: cls for cls in classes}


REGISTRY = registry(
    ExplicitEuler, SemiImplicitEuler, RK4, RK4World, Dopri5, DLM, DLM4, ExactSplit, ExactSplit4)


def make_integrator(name, system, tolerance=1e-6, estimates=True):
    """Return the integrator registered as ``name``, built for ``system``.

    ``estimates`` False: nothing reads its error estimates (see ``base.Integrator``).
    Raises ValueError listing the valid names for an unknown one.
    """
    try:
        cls = REGISTRY[name]
    except KeyError:
        raise ValueError(f'unknown integrator {name!r}; valid: {sorted(REGISTRY)}') from None
    if cls.estimate_optional:
        return cls(system, tolerance=tolerance, estimates=estimates)
    return cls(system, tolerance=tolerance)
