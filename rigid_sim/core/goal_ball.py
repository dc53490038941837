# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The nearest solution by a bounded search of the ball it must lie in (exact free flights).

Once a solution at distance ``d`` is known, every nearer one lies in the ball
``{u : distance(u) < d}``. For a free body under the exact flow (no torque, a constant
force) translation and rotation decouple: the centre of mass moves linearly in its own
velocity, so that velocity is unique at every solution, and with it fixed the metric of
"nearest" is ``d^2 = lin^2 + dw . Q dw`` (``Q`` the world inertia for twist unknowns, see
:func:`~rigid_sim.core.goal_grid.ellipsoid`). The search is over the three angular
unknowns, in the ellipsoid ``dw . Q dw < d^2 - lin^2``, which whitened (``z = C^T dw``,
``Q = C C^T``) is a ball of radius ``r``. The grid, its minima and the batched Newton are
:mod:`~rigid_sim.core.goal_grid`'s, shared with the search where a spring couples the
parts (:mod:`~rigid_sim.core.goal_coupled_ball`).

On the 7 targets of the bench's ``tumbling_long`` (T = 10 s) whose solution was farther
than the known change, the nearer solutions lay 1.0-3.2 rad/s from the one found, not a
plain fold pair nor a whole turn away; no start reached them. The search:

1. flies a grid of spacing ``h = SPACING / sigma_1`` over the ball (``sigma_1`` the
   largest singular value of the end orientation's Jacobian in ``z`` at the solution),
   nearest points first, at most GRID_POINTS, in rows of CHUNK copies: a flight is one
   exact step, ~1.5 us a row;
2. takes the grid points where the residual angle is a local minimum among their 26
   neighbours (at most MINIMA, nearest first);
3. runs a trust-region Newton on the orientation alone from all of them at once
   (ITERATIONS flights of four rows a minimum: the point and its three differences);
4. polishes those within ROOT rad of the goal's orientation, nearest first (at most
   POLISHED), by the goal's own Newton, abandoned when it leaves the ball; the nearest
   converged solution is kept, and never one farther than the solution it started from.
"""
import numpy as np

from rigid_sim.core.goal_grid import (
    ellipsoid, fly_padded, grid, nearest_minima, newton_all, polished)

# rad of end orientation per grid step along the most sensitive direction: the spacing is
# SPACING / sigma_1. Measured on the bench's targets of tumbling_long, tumbling, gravity and
# spinning (100 each, 2026-12-04): 1 and 0.5 took the same solution on all 400; 2 took
# one 1.32 times as far as the known on gravity, and 3 (a first prototype) two farther
# on tumbling_long.
SPACING = 1.0
# Grid points flown, at most: the nearest to the current motion (the ball is cut to the
# radius that holds them). On the same 400 targets 8192 took the same solutions as no cap
# (whose CPU p99 was 1.0-1.1 s on tumbling_long and spinning), 4096 two farther on
# tumbling_long, 2048 five: twice 8192, for margin.
GRID_POINTS = 16384
MINIMA = 512           # local minima Newton starts from, at most: the nearest
ITERATIONS = 8         # of the batched Newton on the orientation
ROOT = 1e-3            # rad: a minimum's Newton that ends nearer the goal is polished
SETTLED = 1e-9         # rad: the batched Newton stops once every minimum's is this near
POLISHED = 4           # polishing starts, at most, each of `iterations` of the goal's Newton
CHUNK = 128   # rows a flight of the grid: one Rollout's copies (built in ~3 ms, once a solver)
# Flights (Rollout.fly calls of CHUNK rows) at most: the grid, the batched Newton's (four
# rows a minimum, its first iterate and ITERATIONS trials); the polishing ones are the
# goal's Newton's, `iterations` + 1 each, counted by the caller.
GRID_FLIGHTS = -(-GRID_POINTS // CHUNK) + (ITERATIONS + 1) * -(-4 * MINIMA // CHUNK)


def applies(problem):
    """Whether the search runs: a flight of one exact step, twist or angular unknowns."""
    return problem.exact and problem.goal.unknowns in ('twist', 'angular')


class _Orientation:
    """The end orientation's residual (K, 3) at whitened spins ``z`` (K, 3), in CHUNK rows."""

    def __init__(self, problem, rollout, values, centre, whitening):
        self.problem, self.rollout, self.values = problem, rollout, values
        self.centre, self.unwhiten = problem.current[-3:] + centre, np.linalg.inv(whitening.T)
        rollout.prepare(problem.fine, problem.y)

    def spin_at(self, z):
        """Return the spins (K, 3) in rad/s at whitened coordinates (K, 3)."""
        return self.centre + z @ self.unwhiten.T

    def __call__(self, z):
        rows = self.problem.start_rows(self.values(self.spin_at(z) - self.problem.current[-3:]))
        finals = [fly_padded(self.rollout, rows[first:first + CHUNK])
                  for first in range(0, len(rows), CHUNK)]
        return self.problem.residual_of(np.concatenate(finals))[:, -3:]


def nearer(problem, best, rollout, iterations):
    """Return ``best`` (a converged Newton) or the nearest solution the search finds.

    ``rollout``: a Rollout of CHUNK copies of the goal's body. Each polishing start gets
    ``iterations`` of the goal's Newton and is abandoned once an iterate leaves the ball.
    """
    values, shift, centre, whitening, lin = ellipsoid(problem, best.values)
    nearest = problem.distance(best.values)
    radius = np.sqrt(max(nearest ** 2 - lin, 0.0))
    # The end orientation's rows are the residual's last three, whatever the unknowns.
    sensitivity = best.jacobian[-3:] @ shift @ np.linalg.inv(whitening.T)
    sigma = np.linalg.norm(sensitivity, 2) if np.isfinite(sensitivity).all() else np.nan
    if not (radius > 0.0 and np.isfinite(sigma) and sigma > 0.0):
        return best
    spacing = SPACING / sigma
    orientation = _Orientation(problem, rollout, values, centre, whitening)
    points, inside, shape = grid(radius, spacing, GRID_POINTS)
    angles = np.full(len(points), np.inf)
    angles[inside] = np.linalg.norm(orientation(points[inside]), axis=1)
    angles[np.isnan(angles)] = np.inf
    minima = nearest_minima(points, angles, shape, MINIMA)
    if not minima.size:
        return best
    ends, angles, _ = newton_all(orientation, points[minima], spacing, ITERATIONS, SETTLED)
    reach = np.einsum('ij,ij->i', ends, ends)
    roots = np.flatnonzero((angles < ROOT) & (reach < radius ** 2))
    roots = roots[np.argsort(reach[roots], kind='stable')][:POLISHED]
    starts = values(orientation.spin_at(ends[roots]) - problem.current[-3:])
    return polished(problem, best, nearest,
                    [(reach[root], start, None) for root, start in zip(roots, starts)],
                    iterations, lin)
