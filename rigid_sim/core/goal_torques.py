# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A held wrench's nearer solutions: Newton from starts that fill the torque ellipsoid.

The force a held wrench needs is unique (the centre of mass moves linearly in it, and it
does not turn the body), so of the metric of "nearest" (:meth:`GoalProblem.distance`) its
part is fixed: a solution nearer than one at distance ``d`` has its torque in the
ellipsoid ``tau . M tau < d^2 - |F|_M^2`` (``M`` the metric's torque block). The torques
that reach one end orientation fill it as a curved lattice: at T = 10 s (the bench's
``wrench_long``) the orientation's Jacobian has singular values ~2000, ~100 and ~30 rad per
N m, and the most sensitive direction points away from the torque ``-2 L0 / T`` that
makes the mean angular momentum vanish (|cosine| median 0.995), so the lattice's sheets
are shells about it, curved on the scale of the ellipsoid, and a walk by the linear model
(:mod:`~rigid_sim.core.goal_lattice`) misses where they bend.

So the ellipsoid is searched: seeded starts drawn uniformly in it (PER_VOLUME for each
rad^3 of its image by the linear model at the solution, none where that image is too short
for another whole turn), nearest first, in batches of BATCH; each batch's Newton runs on a
sketch flight of at most SKETCH_STEPS steps (at T = 10 s the orientation errs by
0.008-0.2 rad on 20 steps, small against a whole turn),
all starts' differences in one compiled call an iteration, a start abandoned once it is
SLACK times farther than the nearest torque so far. What converges is polished on the
coarse flight (batched too), the ellipsoid shrinks to the nearest found, and the batches
stop where their starts lie outside it. The nearest is polished on the fine flight and
kept only if it converges nearer than the solution it started from.

A wrench held in body axes turns its force with the body, so there the force is not
unique and the ellipsoid is only where the search looks (the force fixed at the first
solution's); the fine polish frees all six unknowns, and its solution is kept only if
nearer (on five such targets at T = 10 s it took 0.55-1 times the first's distance).
"""
import math

import numpy as np

from rigid_sim.core.goal_flight import Flight
from rigid_sim.core.goal_newton import MAX_ITERATIONS, Newton, NoConvergence
from rigid_sim.core.goal_problem import COARSE_TOLERANCE, SAME_DISTANCE, TOLERANCE

STARTS = 2048       # drawn in the ellipsoid, at most
BATCH = 64          # starts flown together
ITERATIONS = 8      # of Newton from each start, on the sketch flight
POLISH = 5          # iterations of the coarse polish of a sketch solution
SKETCH_STEPS = 25   # steps of the sketch flight, at most (no more than the coarse one's)
SKETCH_TOLERANCE = 1e-6   # rad: a start has converged on the sketch flight
# Relative: a start's iterate farther than this times the nearest torque is abandoned; a
# sketch solution farther than this is not polished (the sketch's own error moves it).
SLACK = 1.1
SEED = 30000
# Starts a rad^3 of the ellipsoid's image at the goal's time (by the linear model at the
# solution; wrench_long's targets: median 55 rad^3, the tenth percentile 7.5, the
# ninetieth 1300; main's misses 98-40 000), and the image's least diameter (rad) for a
# search at all, half a whole turn (the Jacobian varies across the ellipsoid). At T = 2 s
# (the bench's `wrench`) the diameters are 0.44-5.2 rad, 77 of 100 below pi.
PER_VOLUME = 4.0
LEAST_SPAN = np.pi
# rad of the end orientation a Newton step may aim at, at most: a start farther than a
# turn from its solution is stepped there in parts rather than flung across the lattice.
LONGEST_STEP = 2.0
# Sketch solutions polished on the coarse flight a batch, nearest first, at most; two within
# SAME of each other (relative, by the metric) are one.
POLISHED = 7
SAME = 1e-3
ROWS = np.array([4 * POLISHED, 4 * BATCH])   # the copies a call flies: the fewest that hold it
# Flights, as goals.WORST_FLIGHTS counts them: each call, of the sketch flight or of the
# coarse polish, makes no more work than one flight of the goal's 7 copies on the fine
# grid (the sketch's steps are cut to 7 / (4 BATCH) of the fine flight's, the polish flies
# 4 POLISHED rows of a coarse flight COARSE_GAIN times shorter than the fine one), counted
# as one; then the polish of at most two on the fine flight.
WORST_FLIGHTS = (math.ceil(STARTS / BATCH) * (ITERATIONS + 1 + POLISH + 1)
                 + 2 * (MAX_ITERATIONS + 1))


class _Torques:
    """The end orientation's residual at held torques, the force fixed, many at once."""

    def __init__(self, problem, rollouts, force):
        self.problem, self.rollouts, self.force = problem, rollouts, force
        self.steps = problem.steps[3:]
        self.flight = None
        self._prepared = {}   # copies -> the flight its rollout was last prepared for

    def fly_on(self, flight):
        """Fly the rows over ``flight``."""
        self.flight = flight

    def residuals(self, torques):
        """Return the orientation's residual at each of K <= 4 BATCH torques: (K, 3)."""
        count = len(torques)
        copies = int(ROWS[np.searchsorted(ROWS, count)])
        rollout = self.rollouts(copies)
        if self._prepared.get(copies) is not self.flight:
            rollout.prepare(self.flight, self.problem.y)
            self._prepared[copies] = self.flight
        values = np.empty((copies, 6))
        values[:, :3] = self.force
        values[:count, 3:] = torques
        values[count:, 3:] = torques[0]   # the rows left over fly a copy of the first
        final, _ = rollout.fly(self.problem.start_rows(values), values)
        return self.problem.residual_of(final)[:count, 3:]

    def differences(self, torques):
        """Residuals (K, 3) and forward-difference Jacobians (K, 3, 3): one call."""
        offsets = np.vstack((np.zeros(3), np.diag(self.steps)))
        rows = (torques[:, None, :] + offsets).reshape(-1, 3)
        flown = self.residuals(rows).reshape(len(torques), 4, 3)
        jacobians = (flown[:, 1:] - flown[:, :1]).transpose(0, 2, 1) / self.steps
        return flown[:, 0], jacobians

    def newton(self, torques, iterations, tolerance, reach=None):
        """Batched Newton from ``torques`` (K, 3); the iterates and which converged.

        ``reach(torques) -> bool (K,)``: where an iterate leaves it, that start is dropped.
        """
        torques = torques.copy()
        alive = np.ones(len(torques), dtype=bool)
        converged = np.zeros(len(torques), dtype=bool)
        for iteration in range(iterations + 1):
            active = np.flatnonzero(alive & ~converged)
            if not active.size:
                break
            if iteration == iterations:   # the last iterates' residuals only
                residual = self.residuals(torques[active])
                converged[active] = np.linalg.norm(residual, axis=1) <= tolerance
                break
            residual, jacobian = self.differences(torques[active])
            size = np.linalg.norm(residual, axis=1)
            done = size <= tolerance
            converged[active[done]] = True
            moving = active[~done]
            finite = np.isfinite(residual[~done]).all(axis=1) & np.isfinite(
                jacobian[~done]).all(axis=(1, 2))
            alive[moving[~finite]] = False
            moving, residual = moving[finite], residual[~done][finite]
            jacobian, size = jacobian[~done][finite], size[~done][finite]
            singular = np.abs(np.linalg.det(jacobian)) < 1e-300
            alive[moving[singular]] = False
            moving, residual, jacobian, size = (moving[~singular], residual[~singular],
                                                jacobian[~singular], size[~singular])
            step = np.linalg.solve(jacobian, -residual[..., None])[..., 0]
            torques[moving] += step * np.minimum(1.0, LONGEST_STEP / size)[:, None]
            if reach is not None:
                alive[moving[~reach(torques[moving])]] = False
        return torques, converged & alive


def _ball_points(count):
    """Seeded points (count, 3) uniform in the unit ball, nearest the centre first.

    The first ``count`` of the same STARTS draws, so that fewer starts are as evenly
    spread as more.
    """
    rng = np.random.default_rng(SEED)
    points = rng.standard_normal((STARTS, 3))
    points /= np.linalg.norm(points, axis=1)[:, None]
    points *= rng.uniform(size=(STARTS, 1)) ** (1.0 / 3.0)
    points = points[:count]
    return points[np.argsort(np.linalg.norm(points, axis=1))]


def _distinct(torques, size):
    """Return ``torques`` (K, 3) nearest first, less any within SAME of a nearer one."""
    torques = torques[np.argsort(size(torques))]
    kept = []
    for values in torques:
        if all(size((values - other)[None])[0] > SAME * max(size(values[None])[0], 1e-12)
               for other in kept):
            kept.append(values)
    return np.array(kept).reshape(-1, 3)


def nearer(problem, best, rollouts):
    """Return ``best`` (a converged Newton on the fine flight) or a nearer solution.

    ``problem``: a held wrench's, with a coarse flight; it is left flying the fine one.
    ``rollouts(copies)``: the Rollout of that many copies of the goal's body.
    """
    force = best.values[:3]   # the current wrench unknowns are zero (GoalProblem.current)
    metric = problem.metric[3:, 3:]
    forced = float(force @ problem.metric[:3, :3] @ force)
    radius = math.sqrt(max(problem.distance(best.values) ** 2 - forced, 0.0))
    if not radius > 0.0:
        return best
    steps = min(SKETCH_STEPS, problem.coarse.steps, 7 * problem.grid.steps // (4 * BATCH))
    if steps < 1:
        return best
    torques = _Torques(problem, rollouts, force)
    sketch = Flight(problem.world, steps, problem.horizon / steps, problem.fine.held)

    def size(values):
        return np.sqrt(np.maximum(np.einsum('ij,jk,ik->i', values, metric, values), 0.0))

    spread = np.linalg.inv(np.linalg.cholesky(metric)).T   # unit ball -> metric ball
    # The ellipsoid's image at the goal's time by the linear model at the solution: too
    # short for a whole turn, it holds no other solution; its volume sets the starts.
    image = radius * best.jacobian[3:, 3:] @ spread
    if 2.0 * np.linalg.norm(image, 2) < LEAST_SPAN:
        return best
    volume = 4.0 / 3.0 * np.pi * abs(np.linalg.det(image))
    count = min(STARTS, BATCH * math.ceil(PER_VOLUME * volume / BATCH))
    points = _ball_points(count)
    nearest, found = radius, []
    for first in range(0, count, BATCH):
        batch = points[first:first + BATCH]
        if np.linalg.norm(batch[0]) * radius >= nearest:
            break
        starts = radius * batch @ spread.T
        torques.fly_on(sketch)
        solved, converged = torques.newton(starts, ITERATIONS, SKETCH_TOLERANCE,
                                           lambda t: size(t) <= SLACK * nearest)
        solved = _distinct(solved[converged], size)
        solved = solved[size(solved) <= SLACK * nearest][:POLISHED]
        if not solved.size:
            continue
        torques.fly_on(problem.coarse)
        polished, converged = torques.newton(solved, POLISH, COARSE_TOLERANCE)
        for values in polished[converged]:
            distance = float(size(values[None])[0])
            if distance < nearest * (1.0 - SAME_DISTANCE):
                nearest = distance
                found.append(values)
    problem.fly_on(problem.fine)
    reference = problem.distance(best.values)
    for values in sorted(found, key=lambda t: size(t[None])[0])[:2]:
        polished = Newton(problem, np.concatenate((force, values)))
        try:
            polished.converge(TOLERANCE, iterations=MAX_ITERATIONS)
        except NoConvergence:
            continue
        if problem.distance(polished.values) < reference * (1.0 - SAME_DISTANCE):
            polished.iterations += best.iterations
            return polished
    return best
