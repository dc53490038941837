# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""pytest fixtures of the rigid_sim test kit, registered as the ``rigid_sim`` plugin.

``rigid_sim(scene=... or yaml=..., namespace=..., **parameters)`` starts a
:class:`Simulation` in the test's own rclpy context and executor, with discovery off (only
nodes of this context meet) and a domain of its own, and cleans everything up after the
test. ``rigid_sim_context`` and ``rigid_sim_executor`` are the context and executor, for
nodes of your own.
rclpy is imported only when a fixture is used, so the plugin costs nothing elsewhere.
"""
import os

import pytest


@pytest.fixture
def rigid_sim_context(monkeypatch):
    """Give the test a fresh rclpy context, discovery off, on a domain from the process id."""
    import rclpy
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'OFF')
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=1 + os.getpid() % 101)
    yield context
    rclpy.try_shutdown(context=context)


@pytest.fixture
def rigid_sim_executor(rigid_sim_context):
    """Give a SingleThreadedExecutor on the test's context.

    Not the node's own executor (:mod:`rigid_sim.executor`): between two ticks the kit runs
    every callback that is ready (:func:`rigid_sim.testing.run_ready_callbacks`), which only
    the Python executors can say.
    """
    from rclpy.executors import SingleThreadedExecutor
    executor = SingleThreadedExecutor(context=rigid_sim_context)
    yield executor
    executor.shutdown()


@pytest.fixture
def rigid_sim(rigid_sim_context, rigid_sim_executor):
    """Give the test a starter of simulations.

    Call it with a scene and parameters: ``sim = rigid_sim(yaml=TEXT, time_step=0.01)``;
    ``namespace=`` for each of several simulators in one test.
    """
    from rigid_sim.testing import Simulation
    made = []

    def start(scene=None, yaml=None, namespace=None, **parameters):
        made.append(Simulation(rigid_sim_context, rigid_sim_executor, scene, yaml, namespace,
                               **parameters))
        return made[-1]
    yield start
    for simulation in made:
        simulation.close()
