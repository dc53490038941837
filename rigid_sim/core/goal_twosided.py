# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Two-sided (meet-in-the-middle) shooting: starts for a long goal's Newton.

A long flight that a spring torques is chaotic: its end pose stretches by e every few
seconds, and Newton's basin about a solution shrinks with it. Flown half the way from now
with the unknown twist ``u`` and half the way back from the goal pose with an unknown twist
``w`` at the goal's time, the two halves stretch by the square root of the whole each; they
must meet in pose and twist at the middle (12 equations, 12 unknowns). The ``u`` of a
meeting is only a start: the solver's own Newton on the forward flight then has the last
word.

The flight backward is the flight forward of the time-reversed body: the same pose, the
momenta negated and every damper's coefficient negated (a damper takes energy going forward,
so it gives it back going backward). :class:`ReversedCopies` are those copies.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core.effects.damping import DampingParameters
from rigid_sim.core.effects.springs import (DAMPING_COLUMN, AnchoredSpringParameters,
                                            SpringParameters)
from rigid_sim.core.goal_copies import Copies
from rigid_sim.core.goal_newton import Newton, NoConvergence
from rigid_sim.core.state import packed_rows

# Flights this long (steps) or longer get the two-sided starts: at T = 10 s, dt 1e-2, the
# damped spring stretches the end pose by ~e^4 and Newton's basin is 0.01-0.1 of the twist.
MIN_STEPS = 1000
MEET_STARTS = 3        # the starts of w: the forward end's twist, corrected once, twice
MEET_ITERATIONS = 40
MEET_TOLERANCE = 1e-6  # m, rad, m/s, rad/s: the solver's Newton then finishes the solve
# s: the twist's part of the meeting residual against the pose's. Of the 8 targets of
# `rigid_sim_bench goals --cases springs_long --targets 20` the solver refused without the
# meetings, these three starts of w and the same from the current motion (40 iterations
# each) solve 1 with 1.0, 3 with 0.3, 0 with 0.1; every solve came from the corrected one.
TWIST_WEIGHT = 0.3
FINISH_ITERATIONS = 15   # of the solver's Newton from a meeting, on the fine flight
# Flights of the meetings at worst, one an iteration as goals.WORST_FLIGHTS counts them:
# each start's meeting, the Jacobian at a meeting, the solver's Newton from there.
WORST_FLIGHTS = MEET_STARTS * (MEET_ITERATIONS + 1 + FINISH_ITERATIONS)


def _anti_damped(parameters):
    """``parameters`` with every damping coefficient negated (new arrays)."""
    if isinstance(parameters, DampingParameters):
        return DampingParameters(-parameters.linear, -parameters.angular)
    if isinstance(parameters, AnchoredSpringParameters):
        rows = parameters.rows.copy()
        rows[:, DAMPING_COLUMN] *= -1.0
        return AnchoredSpringParameters(parameters.first, rows)
    if isinstance(parameters, SpringParameters):
        return parameters._replace(damping=-parameters.damping)
    return parameters


class ReversedCopies(Copies):
    """Copies of body ``index``'s group that fly the world's flight backward.

    A copy started from ``reverse(y)`` (:func:`reverse`) and flown ``t`` ends at
    ``reverse`` of the state the world's flight from there would have had ``t`` earlier,
    to the integrator's error: springs and gravity depend on the pose alone, and a damper's
    force ``-c v`` is ``+c v'`` in the reversed velocity ``v' = -v``. The world's effects
    stay as they are: the negated dampers are the copies' own.
    """

    def __init__(self, world, index, copies):
        super().__init__(world, index, copies)
        self._effects = tuple(_anti_damped(p) for p in self._effects)


def reverse(rows):
    """Return states (K, 13) with the momenta negated: the time-reversed body's."""
    turned = np.array(rows, dtype=float, copy=True)
    turned[:, 7:13] *= -1.0
    return turned


def applies(problem):
    """Whether ``problem``'s goal is one the two-sided starts are for.

    Twist unknowns of a body alone (the backward half needs the state of every body it is
    coupled to at the goal's time, which the goal does not give), free of contact and of
    held wrenches (an impact or a hold that runs out breaks the symmetry), over at least
    MIN_STEPS steps of a flight a spring or a damper makes chaotic.
    """
    world, index = problem.world, problem.index
    return (problem.goal.unknowns == 'twist' and not problem.exact and not problem.collides
            and problem.fine.steps >= MIN_STEPS
            and not problem.fine.held.held_mask[index]
            and problem.batch.copies.width == 1
            and any(isinstance(p, (DampingParameters, AnchoredSpringParameters,
                                   SpringParameters)) for p in world.effect_parameters()))


class TwoSided:
    """The meeting of a forward and a backward half flight, as equations for :class:`Newton`.

    Unknowns (12,): the twist now ``u`` (the goal problem's: origin velocity and angular
    velocity, world axes) and the twist at the goal's time ``w`` (the same kind). Residual
    (12,): at the middle, forward less backward, the centre of mass (m), the rotation
    (rad), and TWIST_WEIGHT times the velocity of the centre of mass (m/s) and the angular
    velocity (rad/s).

    Parameters
    ----------
    problem : rigid_sim.core.goal_problem.GoalProblem
        A goal it :func:`applies` to.
    """

    fresh = False   # Broyden's Jacobian between renewals, as on a goal's long flights

    def __init__(self, problem):
        self.problem = problem
        grid = problem.fine
        self.t0, self.dt = grid.t0, grid.dt
        # The fine flight's plan, its largest substeps throughout: halves of one plan.
        self.substeps = max(s for _, s in grid.plan)
        self.first = grid.steps // 2
        self.second = grid.steps - self.first
        bodies, index = problem.world.bodies, problem.index
        self.mass = bodies.mass[index]
        self.inertia_body = np.array(bodies.inertia_body[index], dtype=float)
        self.com = np.array(bodies.com_in_body[index], dtype=float)
        self.goal_pose = tuple(np.array(part, dtype=float) for part in problem.goal_pose)
        self.steps = np.concatenate((problem.steps, problem.steps))
        self.scale = np.concatenate((problem.scale, problem.scale))
        self._pairs = {}

    def _pair(self, count):
        """(forward, backward) copies, ``count`` each, holding the flight's wrenches."""
        if count not in self._pairs:
            world, index = self.problem.world, self.problem.index
            pair = Copies(world, index, count), ReversedCopies(world, index, count)
            for copies in pair:
                copies.inputs = copies.copy_inputs(self.problem.fine.held.parameters)
            self._pairs[count] = pair
        return self._pairs[count]

    def end_rows(self, twists):
        """Return states (K, 13) at the goal pose with twists (K, 6) (origin velocity, spin)."""
        count = len(twists)
        position, orientation = self.goal_pose
        return packed_rows(self.problem.world.bodies, np.full(count, self.problem.index),
                           np.broadcast_to(position, (count, 3)),
                           np.broadcast_to(orientation, (count, 4)), twists[:, :3],
                           twists[:, 3:])

    def twist_of(self, row):
        """Return the twist (6,) (origin velocity, spin) of a state (13,) of the body."""
        turn = Rotation.from_quat(row[3:7]).as_matrix()
        spin = turn @ np.linalg.solve(self.inertia_body, turn.T @ row[10:13])
        return np.concatenate((row[7:10] / self.mass - np.cross(spin, turn @ self.com), spin))

    def halves(self, values):
        """Return the forward and the backward states (K, 13) at the middle, forward in time."""
        forward, backward = self._pair(len(values))
        ahead = self.problem.start_rows(values[:, :6])
        forward.advance(ahead, self.t0, self.first, self.dt, self.substeps)
        # The reversed body's time runs from the goal's; no effect here reads the time.
        behind = reverse(self.end_rows(values[:, 6:]))
        backward.advance(behind, self.t0, self.second, self.dt, self.substeps)
        return ahead, reverse(behind)

    def end_twist(self, values):
        """Return the twist (6,) at the goal's time of the forward flight from ``values`` (6,)."""
        forward, _ = self._pair(1)
        row = self.problem.start_rows(values[None])
        forward.advance(row, self.t0, self.first + self.second, self.dt, self.substeps)
        return self.twist_of(row[0])

    def residuals(self, values):
        """Return the meeting residual (K, 12) at unknowns (K, 12); NaN where a half failed."""
        ahead, behind = self.halves(values)
        failed = ~(np.isfinite(ahead).all(axis=1) & np.isfinite(behind).all(axis=1))
        ahead[failed], behind[failed] = _PARKED, _PARKED
        turns = Rotation.from_quat(ahead[:, 3:7]).as_matrix()
        inverse = turns @ np.linalg.inv(self.inertia_body) @ turns.transpose(0, 2, 1)
        spins = np.einsum('kij,kj->ki', inverse, ahead[:, 10:13] - behind[:, 10:13])
        meet = (Rotation.from_quat(behind[:, 3:7]).inv()
                * Rotation.from_quat(ahead[:, 3:7])).as_rotvec()
        result = np.hstack((ahead[:, :3] - behind[:, :3], meet,
                            TWIST_WEIGHT * (ahead[:, 7:10] - behind[:, 7:10]) / self.mass,
                            TWIST_WEIGHT * spins))
        result[failed] = np.nan
        return result

    def corrected(self, values):
        """``w`` of ``values`` (12,) moved by the least change that closes the pose gap.

        As the solver's first iterate does forward: flown backward for the half, the end
        moves by ``-change * half`` (the reversed body moves at the negated twist).
        """
        ahead, behind = self.halves(values[None])
        gap = np.concatenate((ahead[0, :3] - behind[0, :3],
                              (Rotation.from_quat(ahead[0, 3:7])
                               * Rotation.from_quat(behind[0, 3:7]).inv()).as_rotvec()))
        return values[6:] - gap / (self.second * self.dt)

    @staticmethod
    def close_enough(residual, tolerance):
        """Whether each part of ``residual`` (pose, then twist) is within ``tolerance``."""
        return bool(np.all((residual.reshape(-1, 3) ** 2).sum(axis=1) <= tolerance ** 2))


# A row standing in for a failed half, so that its residual computes (and is then NaN).
_PARKED = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])


def meetings(problem, first):
    """Yield starts (twist now (6,), Jacobian (6, 6)) of the meetings found from ``first``.

    ``w`` starts at the twist at the goal's time of the forward flight from ``first``, then
    at it corrected towards the forward half's middle pose, once and twice
    (:meth:`TwoSided.corrected`). A start whose Newton does not meet within
    MEET_ITERATIONS yields nothing. A meeting is a solution of the fine flight cut in two,
    so its Jacobian there (one flight) lets the solver's Newton finish on the fine flight.
    """
    sides = TwoSided(problem)
    values = np.concatenate((first, sides.end_twist(first)))
    for number in range(MEET_STARTS):
        if number:
            values = np.concatenate((first, sides.corrected(values)))
        newton = Newton(sides, values)
        try:
            newton.converge(MEET_TOLERANCE, iterations=MEET_ITERATIONS)
        except NoConvergence:
            continue
        met = newton.values[:6]
        problem.fly_on(problem.fine)
        yield met, Newton(problem, met).differences(met)[1]
