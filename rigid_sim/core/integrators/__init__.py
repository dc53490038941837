# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Integrators behind one interface (see ``base.Integrator``), chosen by name."""
from rigid_sim.core.integrators.adaptive import Dopri5
from rigid_sim.core.integrators.runge_kutta import RK4, RK4World, ExplicitEuler
from rigid_sim.core.integrators.splitting import DLM, DLM4, ExactSplit, ExactSplit4
from rigid_sim.core.integrators.symplectic_euler import SemiImplicitEuler

# The node's default; chosen from the accuracy benchmark (docs/accuracy.md).
DEFAULT_INTEGRATOR = 'exact_split'

REGISTRY = {cls.name: cls for cls in (
    ExplicitEuler, SemiImplicitEuler, RK4, RK4World, Dopri5, DLM, DLM4, ExactSplit, ExactSplit4)}


def make_integrator(name, system, tolerance=1e-6):
    """Return the integrator registered as ``name``, built for ``system``.

    Raises ValueError listing the valid names for an unknown one.
    """
    try:
        cls = REGISTRY[name]
    except KeyError:
        raise ValueError(f'unknown integrator {name!r}; valid: {sorted(REGISTRY)}') from None
    return cls(system, tolerance=tolerance)
