# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""simulation_interfaces, the simulator-agnostic API of ROS 2, served under the node's name.

As Gazebo serves them under its server node, the services are ``~/<snake_case of the type>``
and the action ``~/simulate_steps``: :mod:`rigid_sim.simulation_state` serves the
simulation's state, stepping, resets and the feature list, :mod:`rigid_sim.entity_services`
the entities' states and :mod:`rigid_sim.spawning` spawns and deletes. The package has no
wheel: where it is missing (a venv without ``rigid_sim_build_interfaces``) the node says
once what it does not serve and how to add it, runs without them, and loads none of their
code.
"""
import importlib.util

from rigid_sim.interface_build import HOW_TO_ADD

SERVED = ('get_simulator_features', 'get_simulation_state', 'set_simulation_state',
          'step_simulation', 'reset_simulation', 'get_entities', 'get_entity_state',
          'get_entities_states', 'set_entity_state', 'spawn_entity', 'delete_entity',
          'simulate_steps (action)')


def serve(node):
    """Serve simulation_interfaces for ``node``; None, after one log line, without the package."""
    if importlib.util.find_spec('simulation_interfaces') is None:
        node.get_logger().info(
            f'simulation_interfaces is not installed: ~/{", ~/".join(SERVED)} are not '
            f'served (the light route ~/step, ~/pause, ~/reset is); {HOW_TO_ADD}')
        return None
    # Imported here only: without the package none of the services' modules is loaded.
    from rigid_sim.simulation_state import SimulationInterfaces
    return SimulationInterfaces(node)
