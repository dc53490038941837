# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The test kit's :class:`Simulation`; see :mod:`rigid_sim.testing`."""
import os
import tempfile
import time
from dataclasses import dataclass

import numpy as np
from rclpy.duration import Duration
from rclpy.executors import TimeoutException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import ReliabilityPolicy

from rigid_sim.core.goals import Goal
from rigid_sim.node import RigidSimNode

__all__ = ['BodyState', 'Simulation', 'run_ready_callbacks']
CONNECT_TIMEOUT = 10.0   # s of wall time for endpoints in one process to match
ACK_TIMEOUT = 5.0        # s of wall time for one publisher's messages to be delivered
MAX_ROUNDS = 1000        # rounds of delivery between two ticks before giving up


@dataclass(frozen=True)
class BodyState:
    """One body's frame as the simulator publishes it: world axes, SI units."""

    position: np.ndarray          # (3,) m, body-frame origin
    orientation: np.ndarray       # (4,) (x, y, z, w), body to world
    velocity: np.ndarray          # (3,) m/s of the body-frame origin
    angular_velocity: np.ndarray  # (3,) rad/s
    time: float                   # s of simulated time


def run_ready_callbacks(executor):
    """Run every callback of ``executor`` that is ready now, without waiting; how many ran."""
    ran = 0
    while True:
        try:
            handler, _, _ = executor.wait_for_ready_callbacks(timeout_sec=0.0)
        except TimeoutException:
            return ran
        handler()
        handler.result()   # raises what the callback raised
        ran += 1


class Simulation:
    """A rigid_sim node on ``scene`` (a file) or ``yaml`` (its text), stepped by the test.

    Parameters
    ----------
    context : rclpy.Context
    executor : rclpy.executors.Executor on that context; the simulator and the nodes of
        :meth:`create_node` are added to it (add your own nodes to it too)
    scene : str, optional
        A scene file (path, or a packaged scene's bare name).
    yaml : str, optional
        The scene's text instead; a mesh in it needs an absolute file name.
    **parameters
        Further parameters of the node (``time_step``, ``integrator``, ...).
    """

    def __init__(self, context, executor, scene=None, yaml=None, **parameters):
        if (scene is None) == (yaml is None):
            raise ValueError('give exactly one of scene (a file) or yaml (its text)')
        self._folder = None
        if yaml is not None:
            self._folder = tempfile.TemporaryDirectory(prefix='rigid_sim_scene_')
            scene = os.path.join(self._folder.name, 'scene.yaml')
            with open(scene, 'w', encoding='utf-8') as stream:
                stream.write(yaml)
        overrides = [Parameter(name, value=value)
                     for name, value in dict(parameters, scene=scene).items()]
        self.context, self.executor = context, executor
        self.node = RigidSimNode(context=context, parameter_overrides=overrides)
        self.node.loop.stop()   # ticks come from step() only
        executor.add_node(self.node)
        self._nodes = []

    def create_node(self, name, **kwargs):
        """Create an rclpy Node in the simulation's context, spun by its executor."""
        node = Node(name, context=self.context, **kwargs)
        self.executor.add_node(node)
        self._nodes.append(node)
        return node

    @property
    def time(self):
        """Return the simulated time, s."""
        return self.node.world.time

    def state(self, body):
        """Return the :class:`BodyState` of the body named ``body`` now."""
        index = self.node.world.bodies.index(body)
        snapshot = self.node.world.snapshot()
        origin, orientation = snapshot.body_frame_pose()
        velocity, angular_velocity = snapshot.body_frame_twist()
        return BodyState(origin[index].copy(), orientation[index].copy(),
                         velocity[index].copy(), angular_velocity[index].copy(), self.time)

    def solve(self, body, pose, at, unknowns=None):
        """Put ``body`` at ``pose`` (position (3,), orientation (4,)) at simulated time ``at``.

        Solves for the body's scene ``goal`` unknowns (or ``unknowns``) from now and applies
        the solution, as a ``~/<body>/goal`` does at a tick; returns the
        :class:`rigid_sim.core.goals.GoalSolution`, or raises GoalRefused saying why.
        """
        index = self.node.world.bodies.index(body)
        wanted = self.node.scene.bodies[index].goal
        goal = Goal(index, *pose, at, unknowns or wanted['unknowns'], wanted['axes'])
        return self.node.goals.solve_now(goal, self.node.settings)

    def step(self, ticks=1):
        """Advance ``ticks`` ticks, settling all messages and callbacks around each one.

        Returns the simulated time after them, s.
        """
        self.connect()
        for _ in range(ticks):
            self.settle()
            self.node.tick()
        self.settle()
        return self.time

    def settle(self):
        """Deliver every message in flight and run callbacks until nothing is left to run."""
        for _ in range(MAX_ROUNDS):
            for node in self.executor.get_nodes():
                for publisher in node.publishers:
                    if publisher.qos_profile.reliability == ReliabilityPolicy.RELIABLE:
                        publisher.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT))
            if run_ready_callbacks(self.executor) == 0:
                return
        raise RuntimeError(f'callbacks still ran after {MAX_ROUNDS} rounds of delivery: '
                           'do they keep publishing to one another?')

    def connect(self):
        """Wait until every endpoint of the other nodes is matched with the simulator's.

        Subscriptions to the simulator's topics, and publishers to its inputs (set_pose and
        set_twist are subscribed to on demand, here at once); RuntimeError naming the topic
        after ``CONNECT_TIMEOUT``.
        """
        sim = self.node
        sim.inputs.subscribe_on_demand()
        outputs = {publisher.topic_name: publisher for publisher in sim.publishers}
        inputs = sim.inputs.topics()
        for node in self.executor.get_nodes():
            if node is sim:
                continue
            for subscription in node.subscriptions:
                if subscription.topic_name in outputs:
                    ours = outputs[subscription.topic_name]
                    self._wait(lambda: subscription.get_publisher_count() >= 1
                               and ours.get_subscription_count() >= 1, subscription.topic_name)
            for publisher in node.publishers:
                if publisher.topic_name in inputs:
                    self._wait(lambda: sim.inputs.subscribe_on_demand()
                               or publisher.get_subscription_count() >= 1, publisher.topic_name)
        sim.refresh_listeners()

    def _wait(self, condition, topic):
        deadline = time.monotonic() + CONNECT_TIMEOUT
        while not condition():
            if time.monotonic() > deadline:
                raise RuntimeError(f'{topic} not matched with the simulator within '
                                   f'{CONNECT_TIMEOUT} s')
            self.executor.spin_once(timeout_sec=0.01)

    def close(self):
        """Remove and destroy the simulator and the nodes made by :meth:`create_node`.

        Closing again does nothing.
        """
        if self.node is None:
            return
        for node in [self.node] + self._nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self._nodes, self.node = [], None
        if self._folder is not None:
            self._folder.cleanup()
            self._folder = None
