# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The nearest twist by a search of the ball of spins, where a spring couples the parts.

The argument of :mod:`~rigid_sim.core.goal_ball`, on a flight of many steps: once a
solution at distance ``d`` is known, a nearer one has ``|dP|^2 / m + dL . I^-1 dL < d^2``.
A spring off the centre of mass couples translation and rotation, so the centre of mass's
velocity is no longer the same at every solution: each spin needs its own, which the end
position fixes (the position is nearly linear in it). At T = 2 s (the bench's
``springs``) the misses' solutions were 2-6 rad/s of spin from the nearest, whose spin was
near the current one, while the centre of mass's velocity of the two differed by
0.03-0.28 m/s. So, as the free body's search does, the grid is over the spins whose part
of the metric is within that of the solution's spin change, ``dw . I dw < d^2 - lin^2``
(``lin`` the solution's linear part: not a bound here, the nearest's linear part may be
smaller), centred at the current spin, nearest first, at most GRID_POINTS; then:

1. each grid point's twist: the spin, the centre of mass's velocity of the solution,
   corrected by CHORDS chord steps of the end position (its Jacobian in the origin's
   velocity at the solution), flown on the coarse flight, a batch of rows a call;
2. the grid points whose residual (position and orientation) is a local minimum among
   their 26 neighbours (at most MINIMA, nearest first);
3. a trust-region Newton on all six unknowns from all of them at once, on the coarse
   flight (ITERATIONS calls of seven rows a minimum), in the metric's whitened
   coordinates;
4. those within ROOT of the goal, nearer than ``d`` and apart from the solution, nearest
   first (at most POLISHED), are polished on the fine flight by the goal's own Newton
   (from the coarse Jacobian), abandoned when an iterate leaves the ball; the nearest
   converged solution is kept, and never one farther than the solution it started from.

The grid's spacing is SPACING rad of the end orientation over the largest of the
sensitivities (the orientation's Jacobian in whitened spin, the largest singular value)
at the solution and at the grid's centre: a solution spinning fast was 13 times as
sensitive as the current spin on one target, and the centre the more sensitive on 38-42
of 100 (by up to 2.8 times).

Measured (docs/goals.md) from the solutions taken before it on the 200 targets
``rigid_sim_bench goals --cases springs`` draws first: it took a solution no farther than
the known change on all 200 (93 and 88 of 100 before), at a median 11-13 ms of CPU.
"""
import math

import numpy as np

from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.goal_grid import (
    DIFFERENCE, ellipsoid, fly_padded, grid, nearest_minima, newton_all, polished)
from rigid_sim.core.goal_problem import COARSE_GAIN

# rad of end orientation per grid step (as goal_ball's; 2 rad left one of the 100 farther).
SPACING = 1.0
# Flown at most, nearest the current spin first (512 or 256 left one of the 100 farther).
GRID_POINTS = 1024
# Chord steps of the centre of mass's velocity at each grid point (none left one farther).
CHORDS = 1
MINIMA = 32            # local minima Newton starts from, at most: the nearest (8 seen)
ITERATIONS = 8         # of the batched Newton on the coarse flight
# m and rad: a minimum's Newton that ends this near is polished on the fine flight. Near
# a fold the coarse flight's own solution may lie beyond it (its errors move the fold):
# beside one known twist the coarse Newton stalled at 1.2e-3 (1e-3 left it farther).
ROOT = 1e-2
SETTLED = 1e-4         # the batched Newton stops once every minimum's residual is this near
POLISHED = 4           # polishing starts, at most, each of `iterations` of the goal's Newton
SAME = 0.01            # relative to d, by the metric: a root this near the solution is it
CHUNK = 128            # rows a call, at most
ROWS = (8, 32, CHUNK)  # the copies of a call: the fewest that hold its rows
# Work: a call of CHUNK rows of the coarse flight (at most 1 / COARSE_GAIN of the fine
# flight's steps) is that of CALL_FLIGHTS flights of the goal's seven copies on the fine
# flight, as goals.WORST_FLIGHTS counts flights.
CALL_FLIGHTS = math.ceil(CHUNK / (COARSE_GAIN * 7))
# Calls at most: the sensitivity at the grid's centre, the grid (each point's chords and
# last flight), the batched Newton's (seven rows a minimum, its first iterate and
# ITERATIONS trials).
CALLS = (1 + (CHORDS + 1) * -(-GRID_POINTS // CHUNK)
         + (ITERATIONS + 1) * -(-7 * MINIMA // CHUNK))
# Flights at most, as goals.WORST_FLIGHTS counts them; the polishing ones are the goal's
# Newton's, `iterations` + 1 each, counted by the caller.
GRID_FLIGHTS = CALL_FLIGHTS * CALLS


def applies(problem):
    """Whether the search runs: twist unknowns on a flight with a coarse grid, no contact.

    And an effect other than a damper torques the body (a spring: it couples the parts).
    A damper alone leaves them apart (the free body's ball, exact there), and on the
    bench's `damping` cases, 100 nearest without it, the search cost 1.08 (T = 2 s) and
    1.58 (T = 10 s) times main's CPU median for nothing.
    """
    index = problem.index
    coupled = any(effect.torqued[index] and not isinstance(effect, Damping)
                  for effect in problem.world.effects)
    return (coupled and problem.goal.unknowns == 'twist' and not problem.exact
            and problem.coarse is not None and not problem.collides)


class _Twists:
    """The goal's residuals (K, 6) at many twists at once, on the coarse flight."""

    def __init__(self, problem, rollouts):
        self.problem, self.rollouts = problem, rollouts
        self._prepared = set()

    def _fly(self, rows):
        copies = next(size for size in ROWS if size >= len(rows))
        rollout = self.rollouts(copies)
        if copies not in self._prepared:
            rollout.prepare(self.problem.coarse, self.problem.y)
            self._prepared.add(copies)
        return fly_padded(rollout, rows)

    def __call__(self, values):
        """Return the residuals (K, 6) at twists ``values`` (K, 6), CHUNK rows a call."""
        rows = self.problem.start_rows(values)
        finals = [self._fly(rows[first:first + CHUNK]) for first in range(0, len(rows), CHUNK)]
        return self.problem.residual_of(np.concatenate(finals))


def _sensitivity(twists, best, values, shift, spins, unwhiten):
    """Return the largest singular value of the end orientation's Jacobian in whitened spin.

    The larger of the solution's (its fine Jacobian) and the grid centre's (forward
    differences, one call of four rows, the centre of mass's velocity of the solution).
    """
    at_best = best.jacobian[3:] @ shift @ unwhiten
    offsets = np.vstack((np.zeros(3), DIFFERENCE * np.eye(3)))
    flown = twists(values(spins + offsets @ unwhiten.T))
    at_centre = (flown[1:, 3:] - flown[:1, 3:]).T / DIFFERENCE
    both = np.array([at_best, at_centre])
    if not np.isfinite(both).all():
        return np.nan
    return max(np.linalg.norm(at_best, 2), np.linalg.norm(at_centre, 2))


def nearer(problem, best, rollouts, iterations):
    """Return ``best`` (a converged Newton on the fine flight) or a nearer solution.

    ``rollouts(copies)``: the Rollout of that many copies of the goal's body. Each
    polishing start gets ``iterations`` of the goal's Newton on the fine flight and is
    abandoned once an iterate leaves the ball. ``problem`` is left flying the fine flight.
    """
    values, shift, centre, whitening, lin = ellipsoid(problem, best.values)
    nearest = problem.distance(best.values)
    radius = math.sqrt(max(nearest ** 2 - lin, 0.0))
    if not radius > 0.0:
        return best
    unwhiten = np.linalg.inv(whitening.T)
    twists = _Twists(problem, rollouts)
    sigma = _sensitivity(twists, best, values, shift, centre, unwhiten)
    if not (np.isfinite(sigma) and sigma > 0.0):
        return best
    spacing = SPACING / sigma
    # The end position's Jacobian in the origin's velocity, the spin kept, at the solution.
    chord = np.linalg.inv(best.jacobian[:3, :3])

    def corrected(z):
        """Twists (K, 6) at whitened spins ``z``, their velocity corrected; residuals."""
        twist = values(centre + z @ unwhiten.T)
        for _ in range(CHORDS):
            twist[:, :3] -= twists(twist)[:, :3] @ chord.T
        return twist, twists(twist)

    points, inside, shape = grid(radius, spacing, GRID_POINTS)
    sizes = np.full(len(points), np.inf)
    starts, residuals = corrected(points[inside])
    sizes[inside] = np.linalg.norm(residuals, axis=1)
    sizes[np.isnan(sizes)] = np.inf
    minima = nearest_minima(points, sizes, shape, MINIMA)
    if not minima.size:
        return best
    row = np.empty(len(points), dtype=int)
    row[inside] = np.arange(len(inside))
    # All six unknowns in the metric's whitened coordinates y = (u - current) L.
    lower = np.linalg.cholesky(problem.metric)
    back = np.linalg.inv(lower)

    def residual_at(y):
        return twists(problem.current + y @ back)
    ends, sizes, jacobians = newton_all(residual_at, (starts[row[minima]] - problem.current)
                                        @ lower, spacing, ITERATIONS, SETTLED)
    reach = np.einsum('ij,ij->i', ends, ends)
    taken = (best.values - problem.current) @ lower
    apart = np.linalg.norm(ends - taken, axis=1) > SAME * nearest   # not the solution again
    roots = np.flatnonzero((sizes < ROOT) & (reach < nearest ** 2) & apart)
    roots = roots[np.argsort(reach[roots], kind='stable')][:POLISHED]
    problem.fly_on(problem.fine)
    # The coarse Jacobian starts the fine flight's, as a coarse-to-fine solve does.
    return polished(problem, best, nearest,
                    [(reach[root], problem.current + ends[root] @ back,
                      jacobians[root] @ lower.T) for root in roots], iterations)
