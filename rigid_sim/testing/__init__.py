# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A test kit: the simulator in your test's own rclpy context and executor, tick by tick.

With pytest, the ``rigid_sim`` fixture (registered through the ``pytest11`` entry point,
see :mod:`rigid_sim.testing.plugin`) gives a :class:`Simulation`; elsewhere build one on
your own context and executor. :meth:`Simulation.step` advances the simulation by whole
ticks and, between two ticks, delivers every message in flight and runs every callback
that is ready, until nothing is left, so your nodes see each tick's outputs, and the
simulator sees their replies, before the next tick: the same test gives the same result
on every run, whatever the machine's load. That holds for reliable publishers and
subscriptions (the ROS default); best-effort ones may still lose messages.

``from rigid_sim.testing import Simulation`` imports rclpy and the node; the package itself
imports nothing until then, so that pytest loading the plugin stays cheap.
"""
__all__ = ['BodyProperties', 'BodyState', 'ErrorEstimate', 'ImuReading', 'Simulation',
           'run_ready_callbacks']


def __getattr__(name):
    if name in __all__:
        from rigid_sim.testing import simulation
        return getattr(simulation, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
