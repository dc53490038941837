# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The test kit's :class:`Simulation`; see :mod:`rigid_sim.testing`."""
import os
import tempfile
import time

from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu, MagneticField
from std_srvs.srv import SetBool, Trigger

from rigid_sim.core.body_state import with_pose, with_twist
from rigid_sim.core.goals import Goal
from rigid_sim.testing.delivery import Late, deliver, run_ready_callbacks, wait_until
from rigid_sim.testing.readings import BodyProperties, BodyState, ErrorEstimate, ImuReading
from rigid_sim.testing.stepped_node import SteppedNode

__all__ = ['BodyProperties', 'BodyState', 'ErrorEstimate', 'ImuReading', 'Simulation',
           'run_ready_callbacks']
CONNECT_TIMEOUT = 10.0   # s of wall time for endpoints in one process to match
STEP_TIMEOUT = 60.0      # s of wall time one step() may take by default
CALL_TIMEOUT = 10.0      # s of wall time a service call may take
SENSORS = (Imu, MagneticField)   # what imu() reads: the latest message of each topic


# s of wall time a scene or integrator change may take to prepare (compiling included)
PREPARATION_TIMEOUT = 600.0


class Simulation:
    """A rigid_sim node on ``scene`` (a file) or ``yaml`` (its text), stepped by the test.

    Parameters
    ----------
    context : rclpy.Context
    executor : rclpy.executors.Executor on that context; the simulator and the nodes of
        :meth:`create_node` are added to it (add your own nodes to it too)
    scene : str, optional
        A scene file (path, or a packaged scene's bare name); neither this nor ``yaml``:
        the packaged default scene.
    yaml : str, optional
        The scene's text instead; a mesh in it needs an absolute file name.
    namespace : str, optional
        Of the node: topics under ``/<namespace>/rigid_sim/``. Several simulators in one
        test need one each (``/clock``, ``/tf`` and ``/diagnostics`` stay shared).
    **parameters
        Further parameters of the node (``time_step``, ``integrator``, ...).
        ``resource_paths`` defaults to ``['/']``: the test is the operator, and its
        scenes and meshes are wherever it writes them.
    """

    def __init__(self, context, executor, scene=None, yaml=None, namespace=None,
                 **parameters):
        if scene is not None and yaml is not None:
            raise ValueError('give one of scene (a file) or yaml (its text), not both')
        self._folder = None
        if yaml is not None:
            self._folder = tempfile.TemporaryDirectory(prefix='rigid_sim_scene_')
            scene = os.path.join(self._folder.name, 'scene.yaml')
            with open(scene, 'w', encoding='utf-8') as stream:
                stream.write(yaml)
        if scene is not None:
            parameters['scene'] = scene
        parameters.setdefault('resource_paths', ['/'])
        overrides = [Parameter(name, value=value) for name, value in parameters.items()]
        self.context, self.executor = context, executor
        self.node, self._nodes = None, []
        try:
            self.node = SteppedNode(context=context, parameter_overrides=overrides,
                                    **({} if namespace is None else {'namespace': namespace}))
            self._refuse_a_second(self.node.get_fully_qualified_name())
        except BaseException:
            self.close()
            raise
        self.node.loop.stop()   # ticks come from step() only
        executor.add_node(self.node)
        self._kit = Node('rigid_sim_kit', namespace=self.node.get_namespace(),
                         context=context)
        executor.add_node(self._kit)
        self._nodes.append(self._kit)
        self._latest = {}         # sensor topic -> its latest message (None before one)
        self._clients = {}        # (service type, name) -> client of the kit's node

    def _refuse_a_second(self, name):
        for node in self.executor.get_nodes():
            if node.get_fully_qualified_name() == name:
                raise ValueError(f'a simulator {name} already runs on this executor: give '
                                 'each its own namespace=')

    def create_node(self, name, **kwargs):
        """Create an rclpy Node in the simulation's context, spun by its executor."""
        node = Node(name, context=self.context, **kwargs)
        self.executor.add_node(node)
        self._nodes.append(node)
        return node

    def topic(self, name):
        """Return the absolute name of the simulator's topic or service ``name`` (``box/pose``).

        A name starting with ``/`` is returned as it is.
        """
        if name.startswith('/'):
            return name
        return f'{self.node.get_fully_qualified_name()}/{name.removeprefix("~/")}'

    @property
    def time(self):
        """Return the simulated time, s."""
        return self.node.world.time

    def _index(self, body):
        return self.node.world.bodies.index(body)   # KeyError naming the bodies

    def state(self, body):
        """Return the :class:`BodyState` of the body named ``body`` now."""
        index = self._index(body)
        snapshot = self.node.world.snapshot()
        origin, orientation = snapshot.body_frame_pose()
        velocity, angular_velocity = snapshot.body_frame_twist()
        return BodyState(origin[index].copy(), orientation[index].copy(),
                         velocity[index].copy(), angular_velocity[index].copy(), self.time)

    def properties(self, body):
        """Return the :class:`BodyProperties` (mass, inertia, centre of mass) of ``body``."""
        index, bodies = self._index(body), self.node.world.bodies
        return BodyProperties(float(bodies.mass[index]), bodies.inertia_body[index].copy(),
                              bodies.com_in_body[index].copy())

    def error_estimate(self):
        """Return the :class:`ErrorEstimate` of the integration now."""
        world = self.node.world
        momentum, energy = world.invariant_drift()
        return ErrorEstimate(world.diagnostics.error_estimate,
                             world.diagnostics.accumulated_error, momentum, energy, self.time)

    def set_state(self, body, pose=None, twist=None):
        """Put ``body`` at ``pose`` and/or give it ``twist`` now; the rest stays as it is.

        ``pose`` is (position (3,) m, orientation (4,) x y z w), ``twist`` is (velocity (3,)
        m/s of the body-frame origin, angular velocity (3,) rad/s), both in world axes, as
        :class:`BodyState` gives them and as the ``set_pose`` and ``set_twist`` topics take
        them. :meth:`state` shows it at once; the outputs carry it from the next tick.
        ValueError, nothing changed, for a non-finite value or a quaternion far from unit.
        """
        index, world = self._index(body), self.node.world
        y = world.y
        if pose is not None:
            y = with_pose(world.bodies, y, index, *pose)
        if twist is not None:
            y = with_twist(world.bodies, y, index, *twist)
        world.y = y

    def imu(self, body, name='imu'):
        """Return the latest :class:`ImuReading` of ``body``'s IMU called ``name``.

        That is the last message on ``~/<body>/<name>`` (and ``~/<body>/<name>/mag`` for a
        magnetometer) received by the kit during :meth:`step`. LookupError before the first
        reading, or when the simulator publishes no such IMU.
        """
        topic = self.topic(f'{body}/{name}')
        if topic not in self._latest:
            known = sorted(t for t in self._latest if not t.endswith('/mag'))
            raise LookupError(f'no IMU publishes on {topic}; the kit follows {known} '
                              '(IMU topics appear at the first step)')
        if self._latest[topic] is None:
            raise LookupError(f'no reading on {topic} yet: step first')
        return ImuReading.from_messages(self._latest[topic], self._latest.get(f'{topic}/mag'))

    def solve(self, body, pose, at, unknowns=None):
        """Put ``body`` at ``pose`` (position (3,), orientation (4,)) at simulated time ``at``.

        Solves for the body's scene ``goal`` unknowns (or ``unknowns``) from now and applies
        the solution, as a ``~/<body>/goal`` does at a tick; returns the
        :class:`rigid_sim.core.goals.GoalSolution`, or raises GoalRefused saying why.
        """
        index = self.node.world.bodies.index(body)
        wanted = self.node.scene.bodies[index].goal
        goal = Goal(index, *pose, at, **dict(wanted, unknowns=unknowns or wanted['unknowns']))
        return self.node.goals.solve_now(goal, self.node.settings)

    def step(self, ticks=1, timeout=STEP_TIMEOUT):
        """Advance ``ticks`` ticks, settling all messages and callbacks around each one.

        ``step(0)`` only delivers what is in flight. TimeoutError, naming ``ticks`` and the
        ticks done, once ``timeout`` s of wall time have passed (None: no limit).

        Returns the simulated time after them, s.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        done = 0
        try:
            self.connect()
            for done in range(ticks):
                deliver(self.executor, deadline)
                if deadline is not None and time.monotonic() >= deadline:
                    raise Late
                self.node.tick()
            done = ticks
            deliver(self.executor, deadline)
        except Late:
            raise TimeoutError(
                f'step({ticks}) ran out of its timeout of {timeout:g} s of wall time after '
                f'{done} of {ticks} ticks (simulated time {self.time:g} s): is a callback '
                'slow, or do nodes keep publishing to one another? (step(n, timeout=...) '
                'for longer runs)') from None
        return self.time

    def settle(self):
        """Deliver every message in flight and run callbacks until nothing is left to run."""
        deliver(self.executor)

    def reset(self):
        """Send the simulation back to its initial state at time 0, as ``~/reset`` does."""
        self._latest = dict.fromkeys(self._latest)   # readings from before are history
        self._succeed(self.call(Trigger, 'reset', Trigger.Request()), 'reset')

    def pause(self, paused=True):
        """Pause integration (``paused=False``: resume), as ``~/pause`` does.

        While paused, :meth:`step` still ticks: inputs are applied and every output is
        published, at the same simulated time.
        """
        self._succeed(self.call(SetBool, 'pause', SetBool.Request(data=paused)), 'pause')

    def resume(self):
        """Resume integration after :meth:`pause`."""
        self.pause(False)

    @staticmethod
    def _succeed(response, service):
        if not response.success:
            raise RuntimeError(f'~/{service} refused: {response.message}')

    def call(self, service_type, name, request, timeout=CALL_TIMEOUT):
        """Call the service ``name`` (the simulator's, or an absolute name); its response.

        Callbacks run while it waits, and everything it made the nodes publish is delivered
        before it returns. TimeoutError after ``timeout`` s of wall time.
        """
        name = self.topic(name)
        key = (service_type, name)
        if key not in self._clients:
            self._clients[key] = self._kit.create_client(service_type, name)
        client = self._clients[key]
        self._wait(client.service_is_ready, f'service {name}')
        future = client.call_async(request)
        if not wait_until(self.executor, future.done, timeout):
            client.remove_pending_request(future)
            raise TimeoutError(f'{name} did not answer within {timeout:g} s')
        self.settle()
        return future.result()

    def set_parameters(self, **values):
        """Set parameters of the simulator, as ``ros2 param set`` would; the results.

        A refused value changes nothing (see each SetParametersResult's reason). A scene,
        integrator or tolerance is prepared beside the running scene, as the node does it,
        and swapped in (a scene at time 0) or refused before this returns: a refusal then
        leaves the parameter as it was, and the reason in
        ``node.reconfiguration.last_refusal`` and on /diagnostics.
        """
        results = self.node.set_parameters([Parameter(name, value=value)
                                            for name, value in values.items()])
        if not self.node.reconfiguration.wait(PREPARATION_TIMEOUT):
            raise TimeoutError(f'a change of {sorted(values)} was not prepared within '
                               f'{PREPARATION_TIMEOUT:g} s')
        self.settle()
        return results

    def connect(self):
        """Wait until every endpoint of the other nodes is matched with the simulator's.

        Subscriptions to the simulator's topics, and publishers to its inputs (set_pose and
        set_twist are subscribed to on demand, here at once); RuntimeError naming the topic
        after ``CONNECT_TIMEOUT``. The kit itself follows every IMU topic from here on.
        """
        sim = self.node
        sim.inputs.subscribe_on_demand()
        self._follow_sensors()
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

    def _follow_sensors(self):
        """Subscribe the kit's node to every IMU and magnetometer topic not followed yet."""
        for publisher in self.node.publishers:
            topic = publisher.topic_name
            if publisher.msg_type in SENSORS and topic not in self._latest:
                self._latest[topic] = None
                self._kit.create_subscription(
                    publisher.msg_type, topic,
                    lambda message, topic=topic: self._latest.__setitem__(topic, message), 10)

    def _wait(self, condition, topic):
        if not wait_until(self.executor, condition, CONNECT_TIMEOUT):
            raise RuntimeError(f'{topic} not matched with the simulator within '
                               f'{CONNECT_TIMEOUT} s')

    def close(self):
        """Remove and destroy the simulator and the nodes made by :meth:`create_node`.

        Closing again does nothing.
        """
        if self.node is not None:
            for node in [self.node] + self._nodes:
                if node in self.executor.get_nodes():
                    self.executor.remove_node(node)
                node.destroy_node()
            self._nodes, self.node = [], None
        if self._folder is not None:
            self._folder.cleanup()
            self._folder = None
