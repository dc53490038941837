# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The neighbours of a held wrench's solution a whole turn of the end orientation away.

Over a long flight a held torque turns a spinning body through many turns, and the end
orientation is far more sensitive to the torque along one direction than along the
others: at T = 10 s (the bench's ``wrench_long``) the orientation rows of the Jacobian
have singular values 1400-2300 against 12-840 rad per N m. So the torques that reach one
pose lie about ``2 pi / sigma_1`` apart (0.003 N m) along that direction, while the force
(the centre of mass moves linearly in it) is unique and dominates the metric of
"nearest": the solutions found first are mostly 1.001-1.05 times as far as the nearest.
From a solution ``u``, Newton is started at ``u + J^-1 (0, 2 pi n e_1)`` (``e_1`` the
orientation's most sensitive direction, ``n`` a few whole turns either way): the linear
model's spacing is rough over a whole turn, so the polish of the start at ``n = 1`` often
fails or returns to ``u`` and one at ``n = 3`` reaches the next solution. Starts ACROSS
rad along the two other directions reach the stretches of the lattice beside. The nearest
found becomes ``u`` and the walk goes on. It runs on the coarse flight (several times
fewer steps), and its nearest solution is polished on the fine flight, kept only if it
converges nearer.
"""
import numpy as np

from rigid_sim.core.goal_newton import MAX_ITERATIONS, Newton, NoConvergence
from rigid_sim.core.goal_problem import COARSE_TOLERANCE, SAME_DISTANCE, TOLERANCE

TURNS = (1, -1, 2, -2, 3, -3, 4, -4)   # whole turns about the sensitive direction tried
# rad, of the end orientation along each of the two other directions, both ways: where
# the walk missed the nearest solution, it lay 1.2-1.5 rad across them (linear model).
ACROSS = 1.5
ROUNDS = 4         # walks on from a nearer solution at most
ITERATIONS = 10    # of Newton from each start, on the coarse flight
# A start's iterates farther than this times the nearest distance are abandoned: the
# force is unique and dominates the metric, so a start that heads for a farther solution
# soon leaves it (wrench_long, 100 targets, at once: 1.02 and 1.002 both 89 nearest, CPU
# median 362 and 261 ms; 1.0, 88).
SLACK = 1.002
# Flights the walk may fly: the solution continued onto the coarse flight, each start of
# each round (one flight for the first iterate's differences, one per iteration), the
# polish on the fine flight.
WORST_FLIGHTS = ((ROUNDS * (len(TURNS) + 4) + 1) * (ITERATIONS + 1) + MAX_ITERATIONS + 1)


def _starts(problem, newton):
    """Return starts a whole turn or a few of the end orientation from ``newton``'s.

    Along the most sensitive direction; then ACROSS along each of the other two.
    """
    rows = len(newton.residual)
    axes = np.linalg.svd(newton.jacobian[rows - 3:, problem.count - 3:])[0].T
    moves = [2.0 * np.pi * whole * axes[0] for whole in TURNS]
    moves += [sign * ACROSS * axis for axis in axes[1:] for sign in (1.0, -1.0)]
    turn = np.zeros(rows)
    starts = []
    for move in moves:
        turn[rows - 3:] = move
        starts.append(newton.values + np.linalg.solve(newton.jacobian, turn))
    return starts


def _converged(problem, start, reach=np.inf):
    """Newton from ``start`` on the coarse flight, or None where it does not converge.

    Or where an iterate is farther than ``reach`` by the metric.
    """
    newton = Newton(problem, start)
    try:
        newton.converge(COARSE_TOLERANCE, lambda values: problem.distance(values) <= reach,
                        ITERATIONS)
    except NoConvergence:
        return None
    return newton


def nearer(problem, best):
    """Return ``best`` (a converged Newton on the fine flight) or a nearer solution.

    ``problem`` must have a coarse flight; it is left flying the fine one.
    """
    problem.fly_on(problem.coarse)
    here = _converged(problem, best.values)
    nearest = problem.distance(best.values)
    walked = None
    for _ in range(ROUNDS if here is not None else 0):
        found = [_converged(problem, start, SLACK * nearest)
                 for start in _starts(problem, here)]
        found = [newton for newton in found if newton is not None]
        step = min(found, key=lambda newton: problem.distance(newton.values), default=None)
        if step is None or problem.distance(step.values) >= nearest * (1.0 - SAME_DISTANCE):
            break
        here = walked = step
        nearest = problem.distance(step.values)
    problem.fly_on(problem.fine)
    if walked is None:
        return best
    polished = Newton(problem, walked.values)
    try:
        polished.converge(TOLERANCE, iterations=MAX_ITERATIONS)
    except NoConvergence:
        return best
    if problem.distance(polished.values) < problem.distance(best.values) * (1.0 - SAME_DISTANCE):
        polished.iterations += best.iterations
        return polished
    return best
