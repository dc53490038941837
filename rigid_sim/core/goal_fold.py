# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The solution across a fold from a twist goal's solution: the near tie no turn links.

Two solutions of an asymmetric tumbling body may be born together at a fold of the map
from the twist now to the pose at the goal's time. Of 12 targets at T = 2 s drawn as the
bench draws them (`tumbling`, `gravity`, 100 each) whose known change was nearer than the
solution taken, 11 were such a pair: the Jacobian's determinant has opposite signs at the
two, its least singular value at the solution taken was 0.007-0.21 rad per rad/s (the
largest ~2), the known twist lay along its right singular vector (|cosine| 0.83-1.0, once
0.55) 0.03-2.2 rad/s away, and the solution taken was 1.0002-1.03 times as far. No whole
turn links them (the end orientation turns 0.01-0.9 rad on the straight way between), so
the branch walk does not reach it.

Near the fold the equations along that direction ``v`` (``w`` the left singular vector)
reduce to a quadratic, ``w . F(u + t v) ~ sigma t + c t^2 / 2``, whose other root
``t = -2 sigma / c`` is the solution across. ``sigma`` and ``c`` come from central
differences of two flights at ``u +- STEP v``. Newton starts there, then halfway: where
the fold is farther the quadratic overshoots (on the 12, the root reached the known on 7,
halfway on one more, where the root's start converged to a farther solution).

Where those find nothing nearer and a flight is one exact step, the curve on which the
equations less that least sensitive one hold, through the solution and its partner, is
followed across the fold until ``w . F`` changes sign, and Newton starts there: on the
12 it reached the known on 9, among them the 3 fold pairs the quadratic missed.
"""
import numpy as np

from rigid_sim.core.goal_newton import Newton, NoConvergence
from rigid_sim.core.goal_problem import COARSE_TOLERANCE, SAME_DISTANCE, TOLERANCE

# m or rad of displacement at the goal's time: the differences' step along v (0.1 rad/s
# at T = 2 s; at 0.5 and 1 rad/s the quadratic fits worse: 6 and 2 of the 12, against 7).
STEP = 0.2
FRACTIONS = (1.0, 0.5)   # of the quadratic's root, the starts tried in this order
# The curve across the fold, followed where the quadratic's starts find nothing nearer
# and a flight is one exact step (on flights of many steps it cost `damping` 1.45 times
# main's CPU median, 124 against 85 ms, and found nothing more there or on `springs`):
# steps along it (m or rad of displacement at the goal's time), at most; Newton
# corrections a step, at most, and the residual (m and rad, of the equations kept) at
# which they stop; the curve is left where it is farther than TRACE_SLACK times the
# nearest distance.
TRACE_STEP = 0.4
TRACE_STEPS = 24
CORRECTIONS = 3
CORRECTED = 1e-6
TRACE_SLACK = 1.5
# Flights at most: the two differences at u +- STEP v; the curve's first Jacobian and
# each step's (one a correction and one after them); each start's are the caller's.
FLIGHTS = 2 + 1 + TRACE_STEPS * (CORRECTIONS + 1)
STARTS = len(FRACTIONS) + 1   # the quadratic's, and the curve's
# Relative: a coarse solution farther than the nearest by more is not polished on the fine
# flight, whose error differs from the coarse one's (a margin chosen, not tuned).
COARSE_MARGIN = 0.02


def _across(problem, newton):
    """Return the quadratic's root (m or rad along v) and the starts across, or (None, [])."""
    values, scale = newton.values, problem.scale
    left, _, right = np.linalg.svd(newton.jacobian / scale)
    direction, normal = right[-1] / scale, left[:, -1]
    ahead, behind = (normal @ problem.residuals((values + sign * STEP * direction)[None])[0]
                     for sign in (1.0, -1.0))
    curvature = (ahead + behind) / STEP ** 2
    if not (np.isfinite(curvature) and curvature != 0.0):
        return None, []
    root = -(ahead - behind) / STEP / curvature
    return root, [values + fraction * root * direction for fraction in FRACTIONS]


def _traced(problem, best, root, reach):
    """Return a start where the curve across the fold from ``best`` meets the goal, or None.

    The goal's equations less the least sensitive one (the left singular vector ``w``
    taken out) leave a curve through ``best``'s solution and the one across the fold.
    It is followed from ``best`` to the side of ``root`` in steps of TRACE_STEP (a
    predictor along its tangent, CORRECTIONS Newton corrections on the plane across it),
    until ``w . F`` changes sign: the start is interpolated there. None where the curve
    leaves ``reach`` by the metric, a flight fails or TRACE_STEPS are taken.
    """
    scale, newton = problem.scale, Newton(problem, best.values)
    point = best.values * scale   # the unknowns in m or rad of displacement
    residual, jacobian = newton.differences(best.values)
    left, _, right = np.linalg.svd(jacobian / scale)
    kept, normal = left[:, :-1], left[:, -1]
    tangent = np.sign(root) * right[-1]
    last = None   # w . F at the last point on the curve
    for _ in range(TRACE_STEPS):
        predicted = point + TRACE_STEP * tangent
        corrected = predicted
        for _ in range(CORRECTIONS + 1):
            residual, jacobian = newton.differences(corrected / scale)
            if not np.isfinite(residual).all():
                return None
            kept_residual = kept.T @ residual
            if np.linalg.norm(kept_residual) <= CORRECTED:
                break
            system = np.vstack((kept.T @ jacobian / scale, tangent))
            corrected = corrected - np.linalg.solve(
                system, np.append(kept_residual, tangent @ (corrected - predicted)))
        if problem.distance(corrected / scale) > reach:
            return None
        height = normal @ residual
        if last is not None and np.sign(height) != np.sign(last):
            share = last / (last - height)
            return (point + share * (corrected - point)) / scale
        last = height
        following = np.linalg.svd(kept.T @ jacobian / scale)[2][-1]
        tangent = following if following @ tangent > 0.0 else -following
        point = corrected
    return None


def _solved(problem, start, reach, nearest, iterations):
    """Newton from ``start``, or None: coarse first, abandoned there unless near enough.

    Where the flight has a coarse grid, a start whose coarse solution is more than
    COARSE_MARGIN farther than ``nearest`` is not flown on the fine flight: most starts
    return to the solution they left or go farther, and the fine flight costs the most.
    NoConvergence where the iterations fail or leave ``reach`` by the metric.
    """
    def bound(values):
        return problem.distance(values) <= reach

    newton = Newton(problem, start)
    if problem.coarse is not None:
        problem.fly_on(problem.coarse)
        newton.converge(COARSE_TOLERANCE, bound, iterations)
        if problem.distance(newton.values) > nearest * (1.0 + COARSE_MARGIN):
            return None
        problem.fly_on(problem.fine)
        newton.residual = None
    newton.converge(TOLERANCE, bound, iterations)
    return newton


def nearer(problem, best, slack, iterations):
    """Return ``best`` (a converged Newton) or the solution across its fold, if nearer.

    Each start gets ``iterations`` (coarse, then fine) and is abandoned once an iterate
    is farther than ``slack`` times the nearest distance; a start predicted beyond it
    is not tried. ``problem`` is left flying the fine flight.
    """
    nearest = problem.distance(best.values)
    reach = slack * nearest
    try:
        root, starts = _across(problem, best)
        for start in starts + [None]:
            if start is None and root is not None and problem.exact:
                start = _traced(problem, best, root, TRACE_SLACK * nearest)
            if start is None or problem.distance(start) > reach:
                continue
            try:
                newton = _solved(problem, start, reach, nearest, iterations)
            except NoConvergence:
                continue
            if (newton is not None
                    and problem.distance(newton.values) < nearest * (1.0 - SAME_DISTANCE)):
                return newton
    finally:
        problem.fly_on(problem.fine)
    return best
