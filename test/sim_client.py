# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A ``rigid_sim_node`` process and a client of its simulation_interfaces, over DDS.

The client lives in the test process and uses the types built from the Jazzy definitions
(``rigid_sim_build_interfaces``); the node is the installed console script, started in a
namespace of its own. Waits are on answers, never on sleeps. Imported by the tests as
``sim_client`` (pytest puts ``test/`` on sys.path).
"""
import os
from pathlib import Path
import signal
import subprocess
import sys

import rclpy
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from simulation_interfaces import srv
from simulation_interfaces.msg import Result, SimulationState
from simulation_interfaces.action import SimulateSteps

import processes
from ros_tools import TIMEOUT, spin_until

EXECUTABLE = Path(sys.executable).with_name('rigid_sim_node')
START_TIMEOUT = 600.0  # s: imports, a cold compile, discovery, on a loaded 2-core machine
SERVICES = {'get_simulator_features': srv.GetSimulatorFeatures,
            'get_simulation_state': srv.GetSimulationState,
            'set_simulation_state': srv.SetSimulationState,
            'step_simulation': srv.StepSimulation, 'reset_simulation': srv.ResetSimulation,
            'get_entities': srv.GetEntities, 'get_entity_state': srv.GetEntityState,
            'get_entities_states': srv.GetEntitiesStates,
            'set_entity_state': srv.SetEntityState, 'spawn_entity': srv.SpawnEntity,
            'delete_entity': srv.DeleteEntity}


class SimProcess:
    """``rigid_sim_node`` on ``scene`` in namespace ``namespace``, and a client node.

    Parameters
    ----------
    scene : str
        Scene file of the node.
    namespace : str
        The node's namespace; its services are ``<namespace>/rigid_sim/<name>``.
    cwd : pathlib.Path
        Working directory of the node process.
    parameters : str
        ``name:=value`` parameter overrides.
    """

    def __init__(self, scene, namespace, cwd, *parameters):
        assert EXECUTABLE.is_file(), f'{EXECUTABLE} missing: pip install -e . first'
        arguments = [argument for parameter in (f'scene:={scene}', *parameters)
                     for argument in ('-p', parameter)]
        self.process = processes.start(
            [str(EXECUTABLE), '--ros-args', '-r', f'__ns:={namespace}', *arguments], cwd=cwd,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.prefix = f'{namespace}/rigid_sim'
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = Node(f'client{os.getpid()}', context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.clients = {name: self.node.create_client(kind, f'{self.prefix}/{name}')
                        for name, kind in SERVICES.items()}
        self.action = ActionClient(self.node, SimulateSteps, f'{self.prefix}/simulate_steps')
        spin_until(self.executor, lambda: all(c.service_is_ready()
                                              for c in self.clients.values()),
                   START_TIMEOUT, 'the simulation_interfaces services')
        assert self.action.wait_for_server(timeout_sec=TIMEOUT)
        # The server is ready once its services are; feedback sent before the topic is
        # matched would be lost.
        feedback = f'{self.prefix}/simulate_steps/_action/feedback'
        spin_until(self.executor, lambda: self.node.count_publishers(feedback) >= 1,
                   TIMEOUT, 'the action feedback topic')

    def call(self, service, **fields):
        """Call ``service`` (a name in SERVICES) with request ``fields``; the response."""
        request = SERVICES[service].Request(**fields)
        future = self.clients[service].call_async(request)
        spin_until(self.executor, future.done, TIMEOUT, f"{service} answered")
        return future.result()

    def until(self, condition, what):
        """Spin the client until ``condition()``."""
        spin_until(self.executor, condition, TIMEOUT, what)

    def close(self):
        """Stop the node (SIGINT: it exits 0) and the client; the node's output."""
        self.process.send_signal(signal.SIGINT)
        try:
            status = self.process.wait(timeout=TIMEOUT)
        finally:
            processes.end(self.process)
            output = self.process.communicate()[0]
            self.executor.shutdown()
            self.node.destroy_node()
            rclpy.try_shutdown(context=self.context)
        assert status == 0, output
        return output


def stop_simulation(sim):
    """Stop ``sim`` (a SimProcess): the scene as loaded, paused, at time 0; return it.

    Already stopped, bodies may have been spawned since: then the scene is reset too.
    """
    state = SimulationState(state=SimulationState.STATE_STOPPED)
    answer = sim.call('set_simulation_state', state=state).result.result
    assert answer in (Result.RESULT_OK, srv.SetSimulationState.Response.ALREADY_IN_TARGET_STATE)
    if answer != Result.RESULT_OK:
        assert sim.call('reset_simulation').result.result == Result.RESULT_OK
    return sim
