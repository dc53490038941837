# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Goals: where a body must be at a future time, and the motion now that takes it there.

As in Popovic, Seitz, Erdmann, Popovic and Witkin's interactive control of rigid-body
simulations (SIGGRAPH 2000), the unknowns are what a user may change now: the body's twist
(both parts, or the linear or angular part alone) or a constant wrench held until the
goal's time. Newton's method (:mod:`~rigid_sim.core.goal_newton`) finds them from flights
made by the world's own integrator (:mod:`~rigid_sim.core.goal_flight`), its Jacobian by
forward differences of copies of the body flown together in one compiled call. Of the
solutions it finds (by continuation from the current motion, from the current motion
corrected by the least move that closes its gap, on the branches a whole turn away; for a
held wrench, on the lattice of whole turns of the end orientation,
:mod:`~rigid_sim.core.goal_lattice`, and by Newton from starts filling the ellipsoid of
nearer torques, :mod:`~rigid_sim.core.goal_torques`; for the others, across the fold
beside the solution, :mod:`~rigid_sim.core.goal_fold`, and where a flight is one exact
step, in the ball the nearest must lie in, :mod:`~rigid_sim.core.goal_ball`) it
takes the nearest to the current motion by the impulse norm of
:meth:`GoalProblem.distance <rigid_sim.core.goal_problem.GoalProblem.distance>`. The
equations are :mod:`~rigid_sim.core.goal_problem`'s.

A solution is reported with its errors (m, rad), iterations, wall time and the Jacobian's
condition; a goal that cannot be reached within the scene's limits (a wrench above
``max_force`` or ``max_torque``, a twist above the goal's ``max_speed`` or ``max_spin``, a
motion the step guard cannot resolve, no convergence, any part of the pose left more than
ACCEPTED from the goal) is refused with :class:`GoalRefused` saying why, and nothing
changes.
"""
import time
from dataclasses import dataclass
from functools import partial

import numpy as np

from rigid_sim.core.body_state import unit_quaternion, with_twist
from rigid_sim.core import (goal_ball, goal_coupled_ball, goal_fold, goal_lattice, goal_torques,
                            goal_twosided)
from rigid_sim.core.goal_flight import GOAL_KEY, GoalRefused, Rollout
from rigid_sim.core.goal_newton import MAX_ITERATIONS, LeftTheBound, Newton, NoConvergence
from rigid_sim.core.goal_problem import (COARSE_TOLERANCE, SAME_DISTANCE, TOLERANCE, UNKNOWNS,
                                         GoalProblem)

__all__ = ['ACCEPTED', 'MAX_SPEED', 'MAX_SPIN', 'UNKNOWNS', 'WRENCH_AXES', 'Goal',
           'GoalRefused', 'GoalSolution', 'GoalSolver']
WRENCH_AXES = ('world', 'body')
ACCEPTED = 1e-9   # m and rad: a solution further from the goal, in any part, is refused
# Defaults of a goal's speed limits (scene key ``goal: {max_speed, max_spin}``): m/s of the
# body frame origin and rad/s of a solved twist. A goal far away is reached by a fast enough
# motion whatever its distance; past these it is refused rather than flown at any speed.
MAX_SPEED = 100.0
MAX_SPIN = 100.0
# Starts drawn around the first iterate after the first two fail: how many, how far (m or
# rad of displacement at the goal's time, per unknown) and from which seed.
RESTARTS = 8
RESTART_SPREAD = 0.6
RESTART_SEED = 20000
# The branches of whole turns: starts tried after the first solution, at most; a start
# predicted further than BRANCH_SLACK times the nearest solution's distance is not tried;
# starts or solutions within SAME_START of each other (relative, by the metric) are one.
BRANCH_STARTS = 6
BRANCH_SLACK = 1.5
BRANCH_ITERATIONS = 15   # a stage, of a start on another branch or of the continuation
# The continuation from the current motion's end to the goal: its first stage, and the
# smallest (a fraction of the way) before it gives up for the other starts.
CONTINUATION_STAGE = 0.25
# The unknowns whose solutions branch with the spin. A held wrench's since the lattice walk
# (:mod:`~rigid_sim.core.goal_lattice`): its solution continued from the current motion
# starts the walk on another stretch of the lattice (wrench_long, T = 10 s: nearest 85 ->
# 87 of 100 alone, 89 with the walk's starts across).
CONTINUED = ('twist', 'angular', 'wrench')
SMALLEST_STAGE = 1.0 / 32.0
SAME_START = 0.05
# The continuation's tries at most: stages never grow, so at most 1 / (SMALLEST_STAGE / 2)
# succeed, and a stage halves at most log2(CONTINUATION_STAGE / SMALLEST_STAGE) + 1 times.
CONTINUATION_TRIES = (int(2.0 / SMALLEST_STAGE)
                      + int(np.log2(CONTINUATION_STAGE / SMALLEST_STAGE)) + 1)
# Starts a whole turn from the corrected current motion (about each of the axes of
# ``problem.whole_turns``, both ways) tried, BRANCH_ITERATIONS each, after the current
# motion fails and before the seeded draws: over a long flight the phase of the spin
# winds several turns, the targets' spread spans neighbouring branches, and the corrected
# start may sit by a fold of the branch next to the target's (tumbling, T = 10 s).
TURN_STARTS = 6
# Flights across a twist solution's fold (:mod:`~rigid_sim.core.goal_fold`): its
# differences and the curve it follows, then each start's, one for its first Jacobian
# and one an iteration, twice over where a coarse flight comes first.
FOLD_FLIGHTS = goal_fold.FLIGHTS + 2 * goal_fold.STARTS * (BRANCH_ITERATIONS + 1)
# Flights of the search of the ball the nearest solution lies in
# (:mod:`~rigid_sim.core.goal_ball`, where a flight is one exact step, after the fold's
# starts; it replaced the two deflated solves, which found nothing it does not): its grid
# and batched Newton in flights of goal_ball.CHUNK rows, then its polishing starts, one
# flight of the goal's copies for the first Jacobian and one an iteration.
BALL_FLIGHTS = goal_ball.GRID_FLIGHTS + goal_ball.POLISHED * (BRANCH_ITERATIONS + 1)
# Flights of the search of the ball where a spring couples the parts
# (:mod:`~rigid_sim.core.goal_coupled_ball`, twist unknowns on a flight with a coarse grid,
# after the fold's starts; never with the other ball's): its calls on the coarse flight,
# each counted as the flights of the goal's copies on the fine flight its work makes, then
# its polishing starts on the fine flight.
COUPLED_FLIGHTS = (goal_coupled_ball.GRID_FLIGHTS
                   + goal_coupled_ball.POLISHED * (BRANCH_ITERATIONS + 1))
# Flights a solve from no start may fly at worst, each iteration one flight, twice over
# where a coarse flight comes first: the continuation, the corrected current motion, the
# other starts (:meth:`GoalSolver._restarted`) and the branches of whole turns; then a
# held wrench's walk on the lattice of whole turns and search of its torque ellipsoid
# (their own bounds) or a twist's starts across its fold and the search of the ball, never
# both. The node decides by it whether a goal is solved in the tick. It counts an
# iteration as one flight: one whose trial steps are all refused flies more, up to 20
# (goal_newton: nine damped trials, a renewed Jacobian, nine more, and a renewal after a
# stale Broyden step), so it bounds iterations, not every flight. Measured (2026-12-05,
# Rollout.fly calls): solves flew 1.5-2.3 flights an iteration, a median of 115-174 and at
# most 432 on 20 targets each of tumbling, springs, wrench and damping, and a goal refused
# on the T = 10 s spring 1700-1770 (test_goals.py checks one within this bound).
# The seeded draws where the two-sided meetings (:mod:`~rigid_sim.core.goal_twosided`) come
# first: as many fewer as leave the meetings' flights within those of the draws left out.
MET_RESTARTS = RESTARTS - int(np.ceil(goal_twosided.WORST_FLIGHTS / (2 * MAX_ITERATIONS)))
WORST_FLIGHTS = (2 * (MAX_ITERATIONS * 3
                      + BRANCH_ITERATIONS * (CONTINUATION_TRIES + BRANCH_STARTS
                                             + TURN_STARTS))
                 + max(2 * MAX_ITERATIONS * RESTARTS,
                       2 * MAX_ITERATIONS * MET_RESTARTS + goal_twosided.WORST_FLIGHTS)
                 + max(goal_lattice.WORST_FLIGHTS + goal_torques.WORST_FLIGHTS,
                       FOLD_FLIGHTS + max(BALL_FLIGHTS, COUPLED_FLIGHTS)))


@dataclass(frozen=True)
class Goal:
    """Where body ``body`` (its index) must be at simulated time ``at``, s.

    ``position`` (3,) m and ``orientation`` (4,) (x, y, z, w) of its frame in the world;
    ``unknowns`` one of UNKNOWNS; ``axes`` of a wrench, 'world' or 'body'; a solved twist
    faster than ``max_speed`` (m/s, the body frame origin) or ``max_spin`` (rad/s) is
    refused.
    """

    body: int
    position: np.ndarray
    orientation: np.ndarray
    at: float
    unknowns: str = 'twist'
    axes: str = 'world'
    max_speed: float = MAX_SPEED
    max_spin: float = MAX_SPIN


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


def _coarse_to_fine(problem, newton, bound=None, iterations=MAX_ITERATIONS):
    """Near the solution on the coarse flight, then to it on the fine one.

    The coarse flight's own solution may lie beyond a fold its errors moved, so a coarse
    solve that stops short still hands its iterate on to the fine flight (unless it left
    the ``bound``).
    """
    problem.fly_on(problem.coarse)
    try:
        newton.converge(COARSE_TOLERANCE, bound, iterations)
    except LeftTheBound:
        raise
    except NoConvergence:
        pass
    problem.fly_on(problem.fine)
    newton.residual = None
    newton.converge(TOLERANCE, bound, iterations)


def _turned(problem, first):
    """Return up to TURN_STARTS starts a whole turn from ``first``, nearest first."""
    turned = [first + shift for shift in problem.whole_turns(first, first)]
    return sorted(turned, key=problem.distance)[:TURN_STARTS]


def _draws(problem, first):
    """Return RESTARTS starts drawn around ``first`` (seeded: a goal solves alike twice)."""
    draws = np.random.default_rng(RESTART_SEED).standard_normal((RESTARTS, first.size))
    return [first + RESTART_SPREAD * draw / problem.scale for draw in draws]


def _near_any(problem, values, others):
    """Whether ``values`` is within SAME_START of any of ``others``, by the metric."""
    return any(problem.distance(values - other + problem.current) <= SAME_START
               * max(problem.distance(values), problem.distance(other), 1e-12)
               for other in others)


def _check_speed(goal, linear, angular):
    """Refuse a solved twist faster than the goal's limits."""
    speed, spin = np.linalg.norm(linear), np.linalg.norm(angular)
    if speed > goal.max_speed:
        raise GoalRefused(f'the goal needs a speed of {speed:.3g} m/s, above the body\'s '
                          f'goal max_speed {goal.max_speed:.3g} m/s')
    if spin > goal.max_spin:
        raise GoalRefused(f'the goal needs a spin of {spin:.3g} rad/s, above the body\'s '
                          f'goal max_spin {goal.max_spin:.3g} rad/s')


def _with_condition(error, newton):
    """``error``'s reason and the condition of the Jacobian where its iterations stopped.

    A large condition says why: the end pose barely moves along some change of the
    unknowns (near a fold of the flight's map), which holds Newton's iterates there.
    """
    if newton.jacobian is None:
        return str(error)
    return f'{error}, the Jacobian\'s condition there {newton.condition():.3g}'


def _unconverged(tried, error):
    """Why a goal none of ``tried`` starts solved within the work bound is refused."""
    return (f'no convergence from any of its {tried} starts within the work bound (at most '
            f'{WORST_FLIGHTS} flights; the last start: {error}). Newton\'s method converges '
            f'only from starts near a solution, and the longer a flight the scene torques '
            f'(a spring, a wrench off the centre of mass) the nearer they must be: a nearer '
            f'goal time is solved more often')


def _unreached(goal, problem, newton, errors):
    """Why a solution that leaves ``errors`` (m, rad) at the goal is refused."""
    left = f'{errors[0]:.3g} m and {errors[1]:.3g} rad from the goal'
    if problem.collides:   # does the goal's own flight, on the planes alone, end elsewhere?
        planned = problem.residuals(newton.values[None])[0].reshape(-1, 3)
        aimed = [error for error, aims in zip(errors, problem.aims) if aims]
        if np.abs(np.linalg.norm(planned, axis=1) - aimed).max() > ACCEPTED:
            return (f'the flight of the whole world ends {left}, elsewhere than the goal\'s '
                    f'own flight, which meets only the ground planes: is another body in '
                    f'the way?')
    if all(problem.aims):
        return f'no convergence: the flight ends {left}'
    aimed = 'position' if problem.aims[0] else 'orientation'
    return (f'{goal.unknowns} unknowns cannot reach the goal pose: the flight that best '
            f'reaches its {aimed} ends {left} (residual above {ACCEPTED:g})')


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

    def solve(self, goal, path=False, start=None, jacobian=None):
        """Return the :class:`GoalSolution` of ``goal``, or raise GoalRefused saying why.

        ``path``: also predict the body's motion (at most PATH_POSES states). ``start``
        (n,) and ``jacobian``: a first iterate and its Jacobian, as a re-solve from a
        later state takes them, tried alone, so that a re-solve's work stays that of one
        start and on its branch; by default the nearest solution (:meth:`_nearest`).
        """
        started = time.perf_counter()
        position, orientation = _check(self.world, goal)
        problem = GoalProblem(self, goal, position, orientation)
        if start is None:
            newton = self._nearest(problem)
        else:   # a re-solve from a later state keeps the branch its start was on
            newton = self._converged(problem, [(start, jacobian)])
        if not problem.wrench:
            _check_speed(goal, *problem.twist(newton.values))
        final, trace = problem.verified(newton, path)
        errors = problem.errors(final)
        if max(errors) > ACCEPTED:
            raise GoalRefused(_unreached(goal, problem, newton, errors))
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

    def _nearest(self, problem):
        """Newton on the branches of whole turns; the solution nearest the current motion.

        The first solutions come from the continuation of the current motion
        (:meth:`_continued`, twist and angular unknowns) and from the corrected current
        motion, the nearer taken (the other starts, :meth:`_restarted`, if neither converges).
        Its neighbours a whole turn away about the candidate axes (``problem.whole_turns``)
        are tried next, nearest start first, and the walk goes on
        from every nearer solution found, until no untried start is predicted within
        BRANCH_SLACK of the nearest distance or BRANCH_STARTS starts have been tried. Then
        a held wrench's lattice walk and the search of its torque ellipsoid (a flight with
        a coarse grid, :func:`~rigid_sim.core.goal_lattice.nearer`,
        :func:`~rigid_sim.core.goal_torques.nearer`), or for twist, linear or angular
        unknowns the starts across the fold beside the nearest solution
        (:func:`~rigid_sim.core.goal_fold.nearer`) and, where a flight is one exact step, the
        search of the ball the nearest must lie in (:func:`~rigid_sim.core.goal_ball.nearer`).
        """
        first = problem.first_iterate()
        found = []
        for solve in (self._continued, lambda p: self._converged(p, [(first, None)])):
            if solve is self._continued and problem.goal.unknowns not in CONTINUED:
                continue
            try:
                found.append(solve(problem))
            except NoConvergence:
                pass
        if not found:
            found = [self._restarted(problem, first)]
        best = min(found, key=lambda newton: problem.distance(newton.values))
        nearest = problem.distance(best.values)
        seen = [newton.values for newton in found] + [first]
        candidates = [first + shift for shift in problem.whole_turns(first, first)]
        candidates += [best.values + shift for shift in problem.whole_turns(best.values, first)]
        for _ in range(BRANCH_STARTS):
            candidates = [c for c in candidates if not _near_any(problem, c, seen)]
            if not candidates:
                break
            candidates.sort(key=problem.distance)
            values = candidates.pop(0)
            if problem.distance(values) > BRANCH_SLACK * nearest:
                break
            seen.append(values)
            reach = BRANCH_SLACK * nearest
            try:
                newton = self._converged(problem, [(values, None)],
                                         lambda u: problem.distance(u) <= reach,
                                         BRANCH_ITERATIONS)
            except NoConvergence:
                continue
            distance = problem.distance(newton.values)
            if distance < nearest * (1.0 - SAME_DISTANCE) and not _near_any(
                    problem, newton.values, [best.values]):
                best, nearest = newton, distance
                candidates += [newton.values + shift
                               for shift in problem.whole_turns(newton.values, first)]
            seen.append(newton.values)
        problem.fly_on(problem.fine)
        goal = problem.goal
        rollouts = partial(self.rollout, problem.index, goal.unknowns, goal.axes)  # (copies)
        if problem.wrench and problem.coarse is not None:
            best = goal_lattice.nearer(problem, best)
            best = goal_torques.nearer(problem, best, rollouts)
        if not problem.wrench:
            best = goal_fold.nearer(problem, best, BRANCH_SLACK, BRANCH_ITERATIONS)
        if goal_ball.applies(problem):
            best = goal_ball.nearer(problem, best, rollouts(goal_ball.CHUNK), BRANCH_ITERATIONS)
        elif goal_coupled_ball.applies(problem):
            best = goal_coupled_ball.nearer(problem, best, rollouts, BRANCH_ITERATIONS)
        return best

    def _restarted(self, problem, first):
        """Newton from the other starts, after the first solves found nothing.

        The current motion as it is, then the starts a whole turn from ``first``
        (:func:`_turned`, BRANCH_ITERATIONS each), then seeded draws around it: a start
        that ends in a local minimum of the residual is followed by the next, which may
        lie in another basin. On a long flight a spring or damper makes chaotic, the
        two-sided meetings (:func:`~rigid_sim.core.goal_twosided.meetings`) come before
        MET_RESTARTS of the draws.
        """
        tries = [([(problem.current, None)], MAX_ITERATIONS),
                 ([(s, None) for s in _turned(problem, first)], BRANCH_ITERATIONS),
                 ([(s, None) for s in _draws(problem, first)], MAX_ITERATIONS)]
        if goal_twosided.applies(problem):   # a chaotic flight: fewer draws, after these
            tries[2:] = [(goal_twosided.meetings(problem, first),
                          goal_twosided.FINISH_ITERATIONS),
                         (tries[2][0][:MET_RESTARTS], MAX_ITERATIONS)]
        tried = 1 + (problem.goal.unknowns in CONTINUED)
        for starts, iterations in tries:
            if not isinstance(starts, list):   # the meetings, found one by one
                tried += goal_twosided.MEET_STARTS
            elif not starts:   # linear unknowns have no whole turns
                continue
            else:
                tried += len(starts)
            try:
                return self._converged(problem, starts, iterations=iterations)
            except NoConvergence as error:
                last = error
        raise NoConvergence(_unconverged(tried, last)) from None

    @staticmethod
    def _continued(problem):
        """Newton along the way from where the current motion ends to the goal.

        The current motion is the solution for its own end; the target moves to the goal
        in stages (halved where a stage fails), each solved from the last solution, so the
        solution found is the one the current motion is continued into.
        """
        values, jacobian, done, stage = problem.current, None, 0.0, CONTINUATION_STAGE
        flight = problem.coarse or problem.fine
        try:
            while done < 1.0:
                reach = min(1.0, done + stage)
                problem.aim_at(*problem.on_the_way(reach))
                newton = Newton(problem, values, jacobian)
                problem.fly_on(flight if reach < 1.0 else problem.fine)
                try:
                    newton.converge(COARSE_TOLERANCE if reach < 1.0 else TOLERANCE,
                                    iterations=BRANCH_ITERATIONS)
                except NoConvergence:
                    if stage < SMALLEST_STAGE:
                        raise
                    stage /= 2.0
                    continue
                values, jacobian, done = newton.values, newton.jacobian, reach
        finally:
            problem.aim_at(*problem.goal_pose)
        return newton

    @staticmethod
    def _converged(problem, starts, bound=None, iterations=MAX_ITERATIONS):
        """Newton from the first of ``starts`` (values, Jacobian or None) that converges.

        A local minimum of the residual holds the iterations of one start; the next may lie
        in another basin. The last failure is the refusal's reason. ``bound`` and
        ``iterations``: as ``Newton.converge`` takes them.
        """
        last = NoConvergence('no start to converge from')
        for values, known in starts:
            newton = Newton(problem, values, known)
            try:
                if problem.coarse is not None and known is None:
                    _coarse_to_fine(problem, newton, bound, iterations)
                else:
                    problem.fly_on(problem.fine)
                    newton.converge(TOLERANCE, bound, iterations)
                return newton
            except NoConvergence as error:
                last = NoConvergence(_with_condition(error, newton))
        raise last

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
