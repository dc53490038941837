# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Effects: each adds world-axes forces and torques about the centre of mass for all bodies.

An effect subclasses :class:`~rigid_sim.core.effects.base.Effect` (which holds the defaults)
and declares

``parameters``
    its arrays, as a NamedTuple class of its own whose compiled kernel it registers: with
    :func:`~rigid_sim.core.effects.base.body_kernel_for` when a body's wrench depends only
    on that body's state, else (it couples bodies) with
    :func:`~rigid_sim.core.effects.base.kernel_for`;
``torqued`` : (N,) bool
    which bodies it may apply a torque to (the rest stay torque-free, which lets
    integrators use the exact free-rotation flow for them);
``velocity_dependent`` : bool
    whether its wrench depends on momenta (dampers): splitting methods then integrate
    their kicks to full order instead of taking one explicit step;
``fastest_rate()`` : float
    the fastest frequency or decay rate it imposes, 1/s, which bounds the step;
``potential_energy(snapshot)`` : float
    stored energy, J (0 for dissipative or external effects).

The scene builds only the effects it lists, and the kernels are compiled for exactly those:
an unlisted effect is not in the compiled step at all. Held wrenches are not an effect but
the world's inputs (:mod:`rigid_sim.core.inputs`).
"""
