# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Goals: where a body must be at a future time, and the motion now that takes it there.

As in Popovic, Seitz, Erdmann, Popovic and Witkin's interactive control of rigid-body
simulations (SIGGRAPH 2000), the unknowns are what a user may change now: the body's twist
(both parts, or the linear or angular part alone) or a constant wrench held until the
goal's time. Newton's method (:mod:`~rigid_sim.core.goal_newton`) finds them from flights
made by the world's own integrator (:mod:`~rigid_sim.core.goal_flight`), its Jacobian by
forward differences of copies of the body flown together in one compiled call. Its first
iterate is the current motion corrected by the smallest move that closes the gap it would
leave, so of the solutions that differ by whole turns the one nearest the current motion is
found. The equations are :mod:`~rigid_sim.core.goal_problem`'s.

A solution is reported with its errors (m, rad), iterations, wall time and the Jacobian's
condition; a goal that cannot be reached within the scene's limits (a wrench above
``max_force`` or ``max_torque``, a motion the step guard cannot resolve, no convergence) is
refused with :class:`GoalRefused` saying why, and nothing changes.
"""
import time
from dataclasses import dataclass

import numpy as np

from rigid_sim.core.body_state import unit_quaternion, with_twist
from rigid_sim.core.goal_flight import GOAL_KEY, GoalRefused, Rollout
from rigid_sim.core.goal_newton import Newton, NoConvergence
from rigid_sim.core.goal_problem import COARSE_TOLERANCE, TOLERANCE, UNKNOWNS, GoalProblem

__all__ = ['ACCEPTED', 'UNKNOWNS', 'WRENCH_AXES', 'Goal', 'GoalRefused', 'GoalSolution',
           'GoalSolver']
WRENCH_AXES = ('world', 'body')
ACCEPTED = 1e-9   # m and rad: a solution further from the goal is refused
# Starts drawn around the first iterate after the first two fail: how many, how far (m or
# rad of displacement at the goal's time, per unknown) and from which seed.
RESTARTS = 8
RESTART_SPREAD = 0.6
RESTART_SEED = 20000


@dataclass(frozen=True)
class Goal:
    """Where body ``body`` (its index) must be at simulated time ``at``, s.

    ``position`` (3,) m and ``orientation`` (4,) (x, y, z, w) of its frame in the world;
    ``unknowns`` one of UNKNOWNS; ``axes`` of a wrench, 'world' or 'body'.
    """

    body: int
    position: np.ndarray
    orientation: np.ndarray
    at: float
    unknowns: str = 'twist'
    axes: str = 'world'


@dataclass(frozen=True)
class GoalSolution:
    """What reaches a goal, and how well; see :meth:`GoalSolver.solve`."""

    goal: Goal
    arrival: float     # s, simulated time at which the body is there: the end of a step
    linear_velocity: np.ndarray   # (3,) m/s of the body frame origin, world; None: wrench
    angular_velocity: np.ndarray  # (3,) rad/s, world; None for a wrench
    wrench: np.ndarray        # (6,) force N, torque N m (centre of mass), goal.axes; or None
    position_error: float     # m, of the body frame origin at arrival
    orientation_error: float  # rad
    iterations: int           # Newton iterations
    seconds: float            # wall time of the solve
    condition: float          # of the Jacobian, unknowns scaled to the displacement they make
    values: np.ndarray        # (n,) the unknowns
    jacobian: np.ndarray      # (m, n) at the solution, the unknowns' own units
    # The predicted motion if asked (else None): times (M,) s, body frame origins (M, 3) m
    # and orientations (M, 4), at most PATH_POSES of them from now to the arrival.
    path: tuple = None


def _check(world, goal):
    """Return the goal's position (3,) and unit orientation (4,); GoalRefused if malformed."""
    if not 0 <= goal.body < world.bodies.count:
        raise GoalRefused(f'no body {goal.body} among {world.bodies.count}')
    if goal.unknowns not in UNKNOWNS or goal.axes not in WRENCH_AXES:
        raise GoalRefused(f'unknowns {goal.unknowns!r} in axes {goal.axes!r}: valid are '
                          f'{tuple(UNKNOWNS)} in {WRENCH_AXES}')
    position = np.asarray(goal.position, dtype=float)
    if position.shape != (3,) or not np.isfinite(position).all():
        raise GoalRefused(f'the goal position must be 3 finite numbers, got {position}')
    try:
        orientation = unit_quaternion(goal.orientation)
    except ValueError as error:
        raise GoalRefused(f'goal {error}') from None
    if not (np.isfinite(goal.at) and goal.at > world.time):
        raise GoalRefused(f'the goal time {goal.at!r} s is not after the simulated time '
                          f'{world.time!r} s')
    if goal.unknowns == 'wrench' and not world.inputs.accepts_wrench[goal.body]:
        raise GoalRefused(f'body {world.bodies.names[goal.body]!r} takes no wrench input')
    return position, orientation


def _coarse_to_fine(problem, newton):
    """Near the solution on the coarse flight, then to it on the fine one.

    The coarse flight's own solution may lie beyond a fold its errors moved, so a coarse
    solve that stops short still hands its iterate on to the fine flight.
    """
    problem.fly_on(problem.coarse)
    try:
        newton.converge(COARSE_TOLERANCE)
    except NoConvergence:
        pass
    problem.fly_on(problem.fine)
    newton.residual = None
    newton.converge(TOLERANCE)


class GoalSolver:
    """Solves goals on ``world`` without changing it; :meth:`apply` applies a solution.

    Parameters
    ----------
    world : rigid_sim.core.world.World
    time_step : float, optional
        s, the size of the world's steps (the node's ``time_step / substeps``): a goal is
        reached at the end of a step of this grid. None: the flight is one step.
    """

    def __init__(self, world, time_step=None):
        self.world = world
        self.time_step = time_step
        self._rollouts = {}   # (body, unknowns, axes, copies) -> Rollout, this integrator's
        self._integrator = world.integrator

    def solve(self, goal, path=False, start=None, jacobian=None, restarts=True):
        """Return the :class:`GoalSolution` of ``goal``, or raise GoalRefused saying why.

        ``path``: also predict the body's motion (at most PATH_POSES states). ``start``
        (n,) and ``jacobian``: a first iterate and its Jacobian, as a re-solve from a
        later state takes them; by default the current motion, corrected. ``restarts``
        False tries ``start`` alone, so that a re-solve's work stays that of one start.
        """
        started = time.perf_counter()
        position, orientation = _check(self.world, goal)
        problem = GoalProblem(self, goal, position, orientation)
        newton = self._converged(problem, start, jacobian, restarts or start is None)
        final, trace = problem.verified(newton, path)
        errors = problem.errors(final)
        if max(e for e, aimed in zip(errors, problem.aims) if aimed) > ACCEPTED:
            raise GoalRefused(f'no convergence: the flight ends {errors[0]:.3g} m and '
                              f'{errors[1]:.3g} rad from the goal')
        condition = newton.condition()
        if not (np.isfinite(condition) and np.isfinite(newton.values).all()):
            raise GoalRefused('the unknowns do not move the body (singular Jacobian)')
        linear = angular = wrench = None
        if problem.wrench:
            wrench = newton.values.copy()
        else:
            linear, angular = problem.twist(newton.values)
        return GoalSolution(goal, problem.grid.arrival, linear, angular, wrench, *errors,
                            newton.iterations, time.perf_counter() - started, condition,
                            newton.values.copy(), newton.jacobian.copy(),
                            problem.poses(trace))

    @staticmethod
    def _converged(problem, start, jacobian, restarts=True):
        """Newton from ``start``, else the corrected current motion, else other starts.

        A local minimum of the residual holds the iterations of one start; the next may lie
        in another basin: the current motion as it is, then RESTARTS draws around the
        corrected one (seeded, so a goal solved twice is solved alike). The last failure is
        the refusal's reason.
        """
        first = problem.first_iterate()
        starts = [] if start is None else [(start, jacobian)]
        if restarts:
            starts += [(first, None), (problem.current, None)]
            draws = np.random.default_rng(RESTART_SEED).standard_normal((RESTARTS, first.size))
            starts += [(first + RESTART_SPREAD * draw / problem.scale, None) for draw in draws]
        for number, (values, known) in enumerate(starts):
            newton = Newton(problem, values, known)
            try:
                if problem.coarse is not None and known is None:
                    _coarse_to_fine(problem, newton)
                else:
                    problem.fly_on(problem.fine)
                    newton.converge(TOLERANCE)
                return newton
            except NoConvergence:
                if number + 1 == len(starts):
                    raise

    def rollout(self, body, unknowns, axes, copies):
        """Return the :class:`Rollout` of ``copies`` copies of ``body``, one per integrator."""
        if self.world.integrator is not self._integrator:
            self._rollouts, self._integrator = {}, self.world.integrator
        key = (body, unknowns, axes, copies)
        if key not in self._rollouts:
            self._rollouts[key] = Rollout(self.world, body, copies,
                                          axes if unknowns == 'wrench' else None)
        return self._rollouts[key]

    def apply(self, solution):
        """Set the solved twist, or hold the solved wrench until the arrival, on the world.

        An earlier goal's wrench on the body is dropped either way.
        """
        goal, world = solution.goal, self.world
        world.inputs.release(goal.body, GOAL_KEY)
        if solution.wrench is not None:
            world.inputs.hold(goal.body, GOAL_KEY, goal.axes, solution.wrench[:3],
                              solution.wrench[3:], expires=solution.arrival)
        else:
            world.y = with_twist(world.bodies, world.y, goal.body, solution.linear_velocity,
                                 solution.angular_velocity)
