# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``~/<body>/goal``: where a body must be at a stamped time; the node finds the motion.

A geometry_msgs/PoseStamped in the world frame, stamped with the simulated time at which
the body frame must be at that pose (zero, or a time not in the future: ``goal_horizon``
seconds from now), rounded to the tick grid. At the next tick the goal is solved by
:class:`rigid_sim.core.goals.GoalSolver` for the unknowns the body's scene entry names
(``goal: {unknowns: ...}``, a twist by default) and the solution applied: a twist as
``set_twist`` sets one, a wrench held until the goal's time. The predicted motion goes out
on ``~/<body>/goal_path`` (nav_msgs/Path) and the outcome, or the reason for a refusal, on
/diagnostics. A refused goal changes nothing.

A solve is Newton's method over flights of the world, from many starts: its work
is the body-steps of one flight (steps times bodies) times the flights it may take, which
no step count bounds. With a wall clock a goal is solved in the tick only where that worst
case stays under ``INLINE_WORK``; the rest run in a worker thread on a snapshot of the world
taken at the tick, so that a goal never holds up /clock or control. The world has moved on
by the time the answer comes, so it is re-anchored at the tick that applies it: solved
again from the world as it is then, from the worker's solution and Jacobian only (no
restarts), which takes a few
one-copy flights where the first solve took many. Where that does not converge, the goal
goes back to the worker from the world as it is then, at most ``CHASES`` times; where even
one flight is above ``INLINE_WORK`` (a large world, a far goal), it is refused, saying so.
Without a wall clock (rate 0, or a loop
stopped for lockstep) every goal is solved in the tick, so a lockstep run stays repeatable
to the bit.

The worker holds at most one goal per body: a newer goal for a body replaces the one still
waiting (the latest wins), and one solved meanwhile is dropped, each reported on
/diagnostics as superseded, so that a flood of goals neither queues solves without end nor
holds a snapshot of the world per message.
"""
import itertools
import queue
import threading
from collections import OrderedDict

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Path
from rclpy.clock import Clock, ClockType

from rigid_sim import bounded_input, conversions, on_demand
from rigid_sim.core.goal_flight import snapshot
from rigid_sim.core.goals import Goal, GoalSolver, WORST_FLIGHTS
from rigid_sim.core.text import shown
from rigid_sim.qos_overrides import QUEUE_DEPTH

DEMAND_REFRESH = 0.5   # s of wall time between two looks for new goal publishers
# Body-steps (world steps of a flight times bodies) a solve in the tick may fly at worst:
# about 10 ms of flights of one body's copies on this machine; a solve that may fly more
# runs in the worker thread.
INLINE_WORK = 20_000
CHASES = 3             # times a goal whose re-anchor failed goes back to the worker
WARNING_PERIOD = 2.0   # s of wall time between two warnings about refused goals


class GoalInput:
    """The goal subscriptions, the solves in flight and their outputs, for one node.

    Parameters
    ----------
    node : rclpy.node.Node
        Owns the topics; its ``loop`` (if it has one) tells whether a wall clock runs.
    scene : rigid_sim.core.scene.Scene
    world : rigid_sim.core.world.World
    """

    def __init__(self, node, scene, world):
        self._node = node
        self._diagnostics = node.create_publisher(DiagnosticArray, '/diagnostics',
                                                  QUEUE_DEPTH)
        self._subscriptions, self._paths = [], {}
        self._inbox = {}      # body index -> newest goal message since the last tick
        self._results = queue.SimpleQueue()   # finished worker solves
        self._jobs = None     # the worker's Jobs, once a solve needs it
        self._latest = {}     # body index -> number of its newest solve in a thread
        self._numbers = itertools.count(1)   # of the solves in a thread, never reused
        self.solved = self.refused = self.superseded = 0
        self.wire(scene, world)
        node.create_timer(DEMAND_REFRESH, self.subscribe_on_demand,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def plan(self, scene):
        """Return resolved goal topic -> body index of ``scene`` (the worker makes it)."""
        return {self._node.resolve_topic_name(f'~/{body.name}/goal'): index
                for index, body in enumerate(scene.bodies)}

    def wire(self, scene, world, plan=None):
        """Take ``scene`` and its ``world``: forget goals, await its bodies' goal topics.

        ``plan`` is what :meth:`plan` made for ``scene`` (None: made now).
        """
        for subscription in self._subscriptions:
            self._node.destroy_subscription(subscription)
        for publisher in self._paths.values():
            self._node.destroy_publisher(publisher)
        self._subscriptions, self._paths, self._inbox = [], {}, {}
        self._forget_jobs()
        self._scene, self._world, self._solver, self._time = scene, world, None, world.time
        self._awaited = self.plan(scene) if plan is None else plan

    def subscribe_on_demand(self):
        """Subscribe to every goal topic that has a publisher in the graph now."""
        if not self._awaited:
            return
        on_demand.make_appeared(self._node.topic_listing, self._awaited, self._subscribe)

    def _subscribe(self, name):
        index = self._awaited.pop(name)
        self._subscriptions.append(bounded_input.subscribe(
            self._node, PoseStamped, name,
            lambda message, index=index: self._store(index, message), QUEUE_DEPTH))

    def topics(self):
        """Fully qualified goal topics, subscribed to or awaited."""
        return {s.topic_name for s in self._subscriptions} | set(self._awaited)

    def _store(self, index, message):
        # The newest goal of a body replaces an older one; an Oversized one is refused at
        # the tick, as any other goal is: one report a tick, however many arrive.
        self._inbox[index] = message

    def apply(self, world, scene, settings):
        """At a tick: apply finished solves, start the goals received since the last one."""
        if world is not self._world:
            self.wire(scene, world)
        if world.time < self._time:   # a reset: goals of the old run are void
            self._inbox = {}
            self._forget_jobs()
        self._time = world.time
        while not self._results.empty():
            self._finish(settings, *self._results.get())
        inbox, self._inbox = self._inbox, {}
        for index, message in inbox.items():
            self._start(index, message, settings)

    def _forget_jobs(self):
        self._latest = {}
        if self._jobs is not None:
            self._jobs.clear()

    def close(self):
        """End the worker thread, if any, once its solve in hand is done (the node is gone)."""
        if self._jobs is not None:
            self._jobs.close()
            self._jobs = None

    def solve_now(self, goal, settings):
        """Solve ``goal`` in this thread and apply it; the GoalSolution (GoalRefused raised)."""
        solution = self._solver_for(settings).solve(goal, path=True)
        self._applied(solution, settings, 'tick')
        return solution

    def _solver_for(self, settings):
        step = settings.time_step / settings.substeps
        if self._solver is None or self._solver.time_step != step:
            self._solver = GoalSolver(self._world, step)
        return self._solver

    def goal(self, index, message, settings):
        """Return the Goal a PoseStamped for body ``index`` asks for; ValueError if none."""
        if message.header.frame_id != settings.world_frame:
            raise ValueError(f'unknown frame_id {shown(message.header.frame_id)}: a goal is '
                             f'given in the world frame; valid: [{settings.world_frame!r}]')
        now, tick = self._world.time, settings.time_step
        at = conversions.to_seconds(message.header.stamp)
        if at <= now:   # zero, or not in the future
            at = now + settings.goal_horizon
        ticks = round((at - now) / tick)
        if ticks < 1:
            raise ValueError(f'the goal time {at!r} s is less than a tick after {now!r} s')
        position, orientation = conversions.pose_arrays(message.pose)
        wanted = self._scene.bodies[index].goal
        return Goal(index, position, orientation, now + ticks * tick, **wanted)

    def _start(self, index, message, settings):
        if isinstance(message, bounded_input.Oversized):
            self._report_refusal(index, message)
            return
        try:
            goal = self.goal(index, message, settings)
            if self._in_tick(goal, settings):
                self._supersede(index)   # an older solve in a thread is void
                self.solve_now(goal, settings)
                return
        except ValueError as error:   # GoalRefused is a ValueError
            self._report_refusal(index, error)
            return
        self._to_worker(goal, settings)

    def _to_worker(self, goal, settings, start=None, chases=0):
        """Queue ``goal`` for the worker, from a snapshot of the world as it is now.

        ``start``: the (values, Jacobian) of an earlier solve to begin from; ``chases``:
        how many times the goal came back from a failed re-anchor.
        """
        index = goal.body
        self._supersede(index)
        number = self._latest[index] = next(self._numbers)
        if self._jobs is None:
            self._jobs = Jobs()
            threading.Thread(target=_work, args=(self._jobs, self._results), daemon=True,
                             name='rigid_sim goals').start()
        self._jobs.put(index, (number, goal, snapshot(self._world),
                               self._solver_for(settings).time_step, self._world, start,
                               chases))

    def _supersede(self, index):
        """Void body ``index``'s solve in the worker, if any: waiting, it is never solved."""
        if self._latest.pop(index, None) is None:
            return
        waiting = self._jobs.take(index)
        self._report_superseded(index, 'waiting' if waiting else 'being solved')

    def _flight_work(self, goal, settings):
        """Body-steps of one flight of the whole world to ``goal``'s time."""
        steps = (goal.at - self._world.time) * settings.substeps / settings.time_step
        return steps * self._world.bodies.count

    def _in_tick(self, goal, settings):
        # A free flight under the exact flow is one step, but not a cheap solve: the search
        # for the nearest solution (continuation, branches of whole turns, the ball) takes a
        # median 20 ms of Python, and a flood of random goals held parameter calls 173 ms at
        # p99 when such solves ran in the tick (docs/goals.md). It goes to the worker too.
        loop = getattr(self._node, 'loop', None)
        return (settings.rate == 0.0 or getattr(loop, 'stopped', True)
                or self._flight_work(goal, settings) * WORST_FLIGHTS <= INLINE_WORK)

    def _finish(self, settings, number, goal, outcome, world, chases):
        if world is not self._world or self._latest.get(goal.body) != number:
            return   # another scene, a reset, or superseded (reported then)
        del self._latest[goal.body]
        if isinstance(outcome, Exception):
            if chases:   # the worker's solution did not hold from the world as it moved on
                outcome = ValueError(
                    f'solved in the worker thread, but not again from the world as it moved '
                    f'on meanwhile, starting from that solution ({chases} of at most '
                    f'{CHASES} tries; a flight that stretches small changes, a spring off '
                    f'the centre of mass, loses its solutions so: a nearer goal time or '
                    f'rate 0 keeps them): {outcome}')
            self._report_refusal(goal.body, outcome)
            return
        work = self._flight_work(goal, settings)
        if work > INLINE_WORK:   # no later tick would fly it either
            self._report_refusal(goal.body, ValueError(
                f'solved in the worker thread but not re-anchored: a flight of the world to '
                f'{goal.at!r} s is {work:.0f} body-steps, more than a tick flies '
                f'({INLINE_WORK}); a nearer goal time reaches it'))
            return
        try:   # re-anchored: from the world as it is now, near the worker's solution
            solution = self._solver_for(settings).solve(
                goal, path=True, start=outcome.values, jacobian=outcome.jacobian)
        except ValueError as error:   # GoalRefused is a ValueError
            self._chase(goal, settings, (outcome.values, outcome.jacobian), chases, error)
            return
        self._applied(solution, settings, 'worker thread, re-anchored at the tick')

    def _chase(self, goal, settings, start, chases, why):
        """Solve ``goal`` again in the worker from the world as it is now; refuse if too often."""
        if chases >= CHASES or goal.at <= self._world.time:
            self._report_refusal(goal.body, ValueError(
                f'not re-anchored at the tick {chases + 1} times: {why}'))
            return
        self._to_worker(goal, settings, start, chases + 1)

    def _applied(self, solution, settings, where):
        self._solver.apply(solution)
        self.solved += 1
        index = solution.goal.body
        name = self._scene.bodies[index].name
        if index not in self._paths:
            self._paths[index] = self._node.create_publisher(Path, f'~/{name}/goal_path',
                                                             QUEUE_DEPTH)
        self._paths[index].publish(conversions.path_message(settings.world_frame,
                                                            *solution.path))
        values = {'body': name, 'unknowns': solution.goal.unknowns,
                  'goal time [s]': solution.goal.at, 'arrival [s]': solution.arrival,
                  'position error [m]': solution.position_error,
                  'orientation error [rad]': solution.orientation_error,
                  'iterations': solution.iterations,
                  'solve time [ms]': 1e3 * solution.seconds,
                  'Jacobian condition': solution.condition, 'solved in': where}
        if solution.wrench is None:
            values.update({'linear velocity [m/s]': solution.linear_velocity,
                           'angular velocity [rad/s]': solution.angular_velocity})
        else:
            values.update({f'force [N] ({solution.goal.axes} axes)': solution.wrench[:3],
                           f'torque [N m] ({solution.goal.axes} axes)': solution.wrench[3:]})
        self._publish(name, DiagnosticStatus.OK, f'goal solved: at the goal at '
                      f'{solution.arrival:.9g} s', values)

    def _report_refusal(self, index, error):
        self.refused += 1
        name = self._scene.bodies[index].name
        self._node.get_logger().warning(f'refused a goal on ~/{name}/goal: {error}',
                                        throttle_duration_sec=WARNING_PERIOD)
        self._publish(name, DiagnosticStatus.WARN, f'goal refused: {error}',
                      {'body': name, 'refused goals': self.refused})

    def _report_superseded(self, index, state):
        self.superseded += 1
        name = self._scene.bodies[index].name
        self._publish(name, DiagnosticStatus.WARN, f'goal superseded: a newer goal for '
                      f'{name!r} came while it was {state} in the worker thread',
                      {'body': name})

    def _publish(self, name, level, summary, values):
        self._diagnostics.publish(conversions.diagnostics(
            f'{self._node.get_name()}: goal {name}', self._world.time, level, summary,
            {**values, 'goals solved': self.solved, 'goals refused': self.refused,
             'goals superseded': self.superseded}))


class Jobs:
    """The worker's goals: at most one per body, the oldest body's first."""

    def __init__(self):
        self._waiting = OrderedDict()   # body index -> job
        self._ready = threading.Condition()
        self._closed = False

    def put(self, index, job):
        """Queue ``job`` for body ``index``, which has none waiting."""
        with self._ready:
            self._waiting[index] = job
            self._ready.notify()

    def take(self, index):
        """Withdraw body ``index``'s waiting job; whether there was one."""
        with self._ready:
            return self._waiting.pop(index, None) is not None

    def clear(self):
        """Withdraw every waiting job."""
        with self._ready:
            self._waiting.clear()

    def close(self):
        """Withdraw every waiting job and end the worker once its solve in hand is done."""
        with self._ready:
            self._waiting.clear()
            self._closed = True
            self._ready.notify()

    def get(self):
        """Return the oldest waiting job, waiting for one if there is none; None once closed."""
        with self._ready:
            while not (self._waiting or self._closed):
                self._ready.wait()
            return None if self._closed else self._waiting.popitem(last=False)[1]


def _work(jobs, results):
    """Solve goals from world snapshots, one after another, until ``jobs`` is closed."""
    while (job := jobs.get()) is not None:
        number, goal, copied, step, world, start, chases = job
        try:
            values, jacobian = start if start is not None else (None, None)
            outcome = GoalSolver(copied, step).solve(goal, start=values, jacobian=jacobian)
        except Exception as error:   # noqa: B902 - whatever it is, the tick reports it
            outcome = error
        results.put((number, goal, outcome, world, chases))
