# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""simulation_interfaces: the simulation's state, stepping, resets and the feature list.

States: playing (not paused), paused, and stopped, which is paused at the initial state:
the node starts stopped when it starts paused, setting STOPPED pauses and resets everything
(ResetSimulation's SCOPE_ALL), and so does that reset while paused; a step, a set state, a
spawn or a delete leaves it. A step while playing is refused with RESULT_OPERATION_FAILED,
as StepSimulation.srv and SimulateSteps.action say. A step is a tick of ``time_step``
(``substeps`` integrator steps).

SimulateSteps' feedback reaches a client made with rclpy's defaults, whose feedback queue
keeps the latest 10 messages and whose goal handle drops any feedback taken after the
result. So the action waits (bounded) until every action client the graph shows has its
feedback subscription discovered before the first step (a message written before that is
never delivered), runs at most one step per ``FEEDBACK_PERIOD`` (a client then has ten
periods to take its queue before one is overwritten) and sends the result ``RESULT_HOLD``
after the last feedback. These are waits on a timer, never sleeps: the executor answers
everything else meanwhile. StepSimulation has none of them.
"""
from time import monotonic

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from simulation_interfaces import msg as si_msg, srv as si_srv
from simulation_interfaces.action import SimulateSteps

from rigid_sim import deferred
from rigid_sim.core.robot_description import SPAWN_FORMATS
from rigid_sim.entity_services import EntityServices, result
from rigid_sim.spawning import SceneEditor, SpawnServices

Result = si_msg.Result
# Steps one call may ask for: 1e7 ticks run for hours of wall time at most, and a bigger
# number is a mistake (a uint64 holds 1.8e19), refused rather than clamped.
MAX_STEPS = 10_000_000
# s of wall time: at least this between two steps of SimulateSteps (at most 200 steps/s), so
# a client's default feedback queue of 10 overflows only if it takes none for 50 ms.
FEEDBACK_PERIOD = 0.005
# s of wall time between the last feedback and the result: a client busy when both arrive
# takes the result first and drops the feedback still queued.
RESULT_HOLD = 0.25
# s: the longest wait for the action clients' feedback subscriptions to be discovered.
DISCOVERY_WAIT = 2.0
# The ResetSimulation scope bits the standard defines (TIME, STATE, SPAWNED; ALL is 255).
DEFINED_SCOPES = 0b111


def features():
    """Return the SimulatorFeatures this node supports, honestly: none it would refuse."""
    f = si_msg.SimulatorFeatures
    message = si_msg.SimulatorFeatures(spawn_formats=list(SPAWN_FORMATS))
    message.features = [
        f.SPAWNING, f.DELETING, f.SPAWNING_RESOURCE_STRING, f.ENTITY_STATE_GETTING,
        f.ENTITY_STATE_SETTING, f.SIMULATION_RESET, f.SIMULATION_RESET_TIME,
        f.SIMULATION_RESET_STATE, f.SIMULATION_RESET_SPAWNED, f.SIMULATION_STATE_GETTING,
        f.SIMULATION_STATE_SETTING, f.SIMULATION_STATE_PAUSE, f.STEP_SIMULATION_SINGLE,
        f.STEP_SIMULATION_MULTIPLE, f.STEP_SIMULATION_ACTION]
    message.custom_info = (
        'rigid_sim: a step is one tick of time_step s. spawn: resource_string is one body '
        'entry of a scene (YAML, as an item of bodies:), uri a scene file (a path or '
        'file://) whose bodies and springs are spawned; entity names are body names; '
        'entity states are body frames in world_frame (accelerations are not filled); '
        'GetEntities filters by name only.')
    return message


class SimulationInterfaces:
    """The standard services and the action for ``node`` (a RigidSimNode)."""

    def __init__(self, node):
        self._node = node
        self.stopped = node.paused   # started paused: at the initial state, stopped
        self.editor = SceneEditor(node)
        self.entities = EntityServices(node, self._left_start)
        self.spawns = SpawnServices(node, self.editor, self._left_start)
        srv = si_srv
        for kind, name, callback in (
                (srv.GetSimulatorFeatures, 'get_simulator_features', self._on_features),
                (srv.GetSimulationState, 'get_simulation_state', self._on_get_state),
                (srv.SetSimulationState, 'set_simulation_state', self._on_set_state),
                (srv.StepSimulation, 'step_simulation', self._on_step),
                (srv.ResetSimulation, 'reset_simulation', self._on_reset)):
            deferred.create_service(node, kind, f'~/{name}', callback)
        self.refused_goals = 0
        self._goal_running = False
        # Its services keep a burst of requests, as the node's own do (deferred.SERVICE_QOS):
        # with rclpy's default of 10 the goals of a burst beyond it were dropped unanswered.
        self.action = ActionServer(node, SimulateSteps, '~/simulate_steps', self._execute,
                                   goal_callback=self._admit,
                                   cancel_callback=lambda goal: CancelResponse.ACCEPT,
                                   goal_service_qos_profile=deferred.SERVICE_QOS,
                                   result_service_qos_profile=deferred.SERVICE_QOS,
                                   cancel_service_qos_profile=deferred.SERVICE_QOS)
        self._waits = WallWaits(node)
        action = f'{node.get_fully_qualified_name()}/simulate_steps/_action'
        self._feedback_topic, self._goal_service = f'{action}/feedback', f'{action}/send_goal'

    def _left_start(self):
        self.stopped = False

    def state(self):
        """Return the SimulationState value now: playing, paused or stopped."""
        s = si_msg.SimulationState
        if not self._node.paused:
            return s.STATE_PLAYING
        # Time 0 too: a ~/step of the light route leaves the initial state as well.
        stopped = self.stopped and self._node.world.time == 0.0
        return s.STATE_STOPPED if stopped else s.STATE_PAUSED

    def _on_features(self, request, response, reply):
        response.features = features()
        return response

    def _on_get_state(self, request, response, reply):
        response.state.state = self.state()
        response.result = result(Result.RESULT_OK)
        return response

    def _on_set_state(self, request, response, reply):
        s, wanted = si_msg.SimulationState, request.state.state
        if wanted == self.state():
            response.result = result(response.ALREADY_IN_TARGET_STATE, 'already in that state')
        elif wanted == s.STATE_QUITTING:
            response.result = result(Result.RESULT_FEATURE_UNSUPPORTED,
                                     'quit the node with a signal (Ctrl-C), not a service')
        elif wanted not in (s.STATE_PLAYING, s.STATE_PAUSED, s.STATE_STOPPED):
            response.result = result(response.INCORRECT_TRANSITION,
                                     f'{wanted} is not a state this node can be set to')
        elif wanted == s.STATE_STOPPED:
            self._node.control.set_paused(True)
            return self.reset(255, lambda refusal: reply(self._stopped(response, refusal)))
        else:
            self._node.control.set_paused(wanted == s.STATE_PAUSED)
            self.stopped = False
            response.result = result(Result.RESULT_OK)
        return response

    def _stopped(self, response, refusal):
        self.stopped = refusal is None
        response.result = (result(Result.RESULT_OK) if refusal is None else
                           result(response.STATE_TRANSITION_ERROR, str(refusal)))
        return response

    def _refuse_steps(self, steps):
        """Why ``steps`` cannot run now ('' if they can), as (code, text)."""
        if not self._node.paused:
            return (Result.RESULT_OPERATION_FAILED, 'steps run only while paused: set '
                    'STATE_PAUSED with ~/set_simulation_state (or ~/pause) first')
        if steps > MAX_STEPS:
            return Result.RESULT_OPERATION_FAILED, f'{steps} steps, above {MAX_STEPS} a call'
        return None

    def _on_step(self, request, response, reply):
        refusal = self._refuse_steps(request.steps)
        if refusal is not None:
            response.result = result(*refusal)
            return response
        self.stopped = self.stopped and request.steps == 0

        def done(ran, why):
            response.result = (result(Result.RESULT_OK) if not why else result(
                Result.RESULT_OPERATION_FAILED, f'ran {ran} of {request.steps} steps: {why}'))
            reply(response)
        self._node.control.start_steps(request.steps, done)
        return deferred.LATER

    def _admit(self, request):
        """Accept a SimulateSteps goal unless one runs: one at a time, the rest rejected.

        Each running goal wakes the executor every 5 ms: 200 goals at once held parameter
        calls to a median of 90 ms. The action protocol carries no reason for a rejection,
        so it is logged, with the count.
        """
        if not self._goal_running:
            self._goal_running = True
            return GoalResponse.ACCEPT
        self.refused_goals += 1
        self._node.get_logger().warning(
            f'SimulateSteps: a goal refused, one runs at a time ({self.refused_goals} refused '
            'since the start)', throttle_duration_sec=1.0)
        return GoalResponse.REJECT

    async def _execute(self, goal):
        """SimulateSteps: one tick per step, feedback after each, stopped by a cancel."""
        try:
            return await self._simulate_steps(goal)
        finally:
            self._goal_running = False

    async def _simulate_steps(self, goal):
        steps, answer = goal.request.steps, SimulateSteps.Result()
        refusal = self._refuse_steps(steps)
        if refusal is not None:
            answer.result = result(*refusal)
            goal.abort()
            return answer
        self.stopped = self.stopped and steps == 0
        await self._feedback_discovered()
        started = monotonic()
        for completed in range(1, steps + 1):
            await self._waits.after(started + FEEDBACK_PERIOD - monotonic())
            started = monotonic()
            if goal.is_cancel_requested:
                goal.canceled()
                answer.result = result(Result.RESULT_OK, f'cancelled after {completed - 1}')
                return answer
            ticked = Future()
            self._node.control.start_steps(1, lambda ran, why: ticked.set_result(why))
            why = await ticked
            if why:
                answer.result = result(Result.RESULT_OPERATION_FAILED,
                                       f'ran {completed - 1} of {steps} steps: {why}')
                goal.abort()
                return answer
            goal.publish_feedback(SimulateSteps.Feedback(completed_steps=completed,
                                                         remaining_steps=steps - completed))
        await self._waits.after(RESULT_HOLD)
        goal.succeed()
        answer.result = result(Result.RESULT_OK)
        return answer

    async def _feedback_discovered(self):
        """Wait until each action client in the graph has its feedback subscription, or a while.

        A client's goal service client and feedback subscription are discovered separately;
        feedback published before the second is lost to it.
        """
        node, deadline = self._node, monotonic() + DISCOVERY_WAIT
        while (node.count_subscribers(self._feedback_topic)
               < node.count_clients(self._goal_service) and monotonic() < deadline):
            await self._waits.after(FEEDBACK_PERIOD)

    def _on_reset(self, request, response, reply):
        r = si_srv.ResetSimulation.Request
        if request.scope != r.SCOPE_ALL and request.scope & ~DEFINED_SCOPES:
            response.result = result(
                Result.RESULT_FEATURE_UNSUPPORTED,
                f'scope {request.scope} has bits the standard does not define '
                f'({request.scope & ~DEFINED_SCOPES:#x}): give SCOPE_DEFAULT, SCOPE_ALL or '
                'a sum of SCOPE_TIME (1), SCOPE_STATE (2), SCOPE_SPAWNED (4); nothing was reset')
            return response

        def done(refusal):
            response.result = (result(Result.RESULT_OK) if refusal is None
                               else result(Result.RESULT_OPERATION_FAILED, str(refusal)))
            reply(response)
        return self.reset(request.scope, done)

    def reset(self, scope, done):
        """Reset by ResetSimulation ``scope`` bits; ``done(refusal or None)``; LATER or None.

        SCOPE_DEFAULT (0) and SCOPE_ALL put back the scene as loaded (deleted bodies too),
        at its initial state and time 0. SCOPE_SPAWNED removes the spawned bodies,
        SCOPE_STATE puts every body at its initial (spawned: spawn) state, SCOPE_TIME sends
        time to 0; either of the last two drops the held wrenches.
        """
        r = si_srv.ResetSimulation.Request
        scope = r.SCOPE_ALL if scope == r.SCOPE_DEFAULT else scope
        node = self._node
        node.loop.end_jobs('ended by ~/reset_simulation')   # as ~/reset ends them

        def then(outcome):
            if isinstance(outcome, Exception):
                return done(outcome)
            reset_parts(node, state=bool(scope & r.SCOPE_STATE), time=bool(scope & r.SCOPE_TIME))
            self.stopped = scope == r.SCOPE_ALL and node.paused
            done(None)
        # In turn with the edits and reloads asked before it: a body whose spawn is still
        # being prepared is removed too, and a reset never works on a scene about to go.
        self.spawns.reset_scene(scope == r.SCOPE_ALL, bool(scope & r.SCOPE_SPAWNED), then)
        return deferred.LATER


class WallWaits:
    """Futures done after a wall-clock delay, from one steady timer: waits, never sleeps."""

    def __init__(self, node):
        self._waiting = []    # (monotonic deadline, Future)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._timer = node.create_timer(FEEDBACK_PERIOD / 5, self._on_timer, clock=steady)
        self._timer.cancel()

    def after(self, seconds):
        """Return a Future done ``seconds`` from now (at once if ``seconds`` <= 0)."""
        future = Future()
        if seconds <= 0.0:
            future.set_result(None)
            return future
        self._waiting.append((monotonic() + seconds, future))
        if self._timer.is_canceled():
            self._timer.reset()
        return future

    def _on_timer(self):
        now = monotonic()
        due = [future for deadline, future in self._waiting if deadline <= now]
        self._waiting = [(deadline, future) for deadline, future in self._waiting
                         if deadline > now]
        if not self._waiting:
            self._timer.cancel()
        for future in due:
            future.set_result(None)


def reset_parts(node, state, time):
    """Reset the state, the time or both of ``node``'s world; either drops held wrenches.

    Both is the node's own reset (``~/reset``). A held wrench was set for the motion and
    the clock it is dropped from: its hold ends at a time of the old run.
    """
    if state and time:
        node.reset()
        return
    world = node.world
    if state:
        world.y = world.initial.copy()
    if time:
        world.time = 0.0
        node.imu_outputs.restart()
        node.health.restart(0.0)
    if state or time:
        world.inputs.release()
        node.inputs.clear()
