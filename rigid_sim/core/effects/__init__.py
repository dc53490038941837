# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Effects: each adds world-axes forces and torques about the centre of mass for all bodies.

An effect is a small object with

``accumulate(snapshot, force, torque)``
    add its contribution into the (N, 3) accumulators, given a
    :class:`rigid_sim.core.state.Snapshot`;
``torqued`` : (N,) bool
    which bodies it may apply a torque to (the rest stay torque-free, which lets
    integrators use the exact free-rotation flow for them);
``velocity_dependent`` : bool
    whether its wrench depends on momenta (dampers): splitting methods then integrate
    their kicks to full order instead of taking one explicit step;
``potential_energy(snapshot)`` : float
    stored energy, J (0 for dissipative or external effects).

The scene builds only the effects it lists, so an unlisted effect is never called.
"""
