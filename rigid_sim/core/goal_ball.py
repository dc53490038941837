# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The nearest solution by a bounded search of the ball it must lie in (exact free flights).

Once a solution at distance ``d`` is known, every nearer one lies in the ball
``{u : distance(u) < d}``. For a free body under the exact flow (no torque, a constant
force) translation and rotation decouple: the centre of mass moves linearly in its own
velocity, so that velocity is unique at every solution, and with it fixed the metric of
"nearest" is ``d^2 = lin^2 + dw . Q dw`` (``Q`` the world inertia for twist unknowns, see
:func:`_ellipsoid`). The search is over the three angular unknowns, in the ellipsoid
``dw . Q dw < d^2 - lin^2``, which whitened (``z = C^T dw``, ``Q = C C^T``) is a ball of
radius ``r``.

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

from rigid_sim.core.goal_newton import Newton, NoConvergence
from rigid_sim.core.goal_problem import SAME_DISTANCE, TOLERANCE

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
DIFFERENCE = 1e-6      # its forward differences' step in z (sqrt(kg) m, ~1e-5 rad/s)
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


def _ellipsoid(problem, best):
    """Return (values, shift, centre dw_c (3,), C (3, 3), lin^2): the ball's coordinates.

    ``values(dw)`` (K, 3) -> (K, n) unknowns with the spin ``w_now + dw`` and the centre of
    mass's velocity of ``best``, ``shift`` (n, 3) their change per unit of ``dw``;
    ``distance(values(dw))^2 = lin^2 + |C^T (dw - dw_c)|^2``.
    """
    now = problem.current[-3:]
    shift = problem.spin_shift()   # (n, 3), the centre of mass's velocity kept
    base = best + shift @ (now - best[-3:])   # best's centre of mass velocity, spin now

    def values(spins):
        return base + spins @ shift.T

    change = base - problem.current
    quadratic = shift.T @ problem.metric @ shift
    linear = shift.T @ problem.metric @ change   # zero for a free body: the parts decouple
    centre = -np.linalg.solve(quadratic, linear)
    lin = change @ problem.metric @ change + linear @ centre
    return values, shift, centre, np.linalg.cholesky(quadratic), max(lin, 0.0)


def _grid(radius, spacing):
    """Return grid points (P, 3) within ``radius``, nearest first, their (side,) * 3 index.

    At most GRID_POINTS: the ball is cut to the radius that holds about that many.
    """
    held = spacing * (0.75 * GRID_POINTS / np.pi) ** (1.0 / 3.0)
    side = int(np.ceil(min(radius, held) / spacing))
    axis = np.arange(-side, side + 1) * spacing
    points = np.stack(np.meshgrid(axis, axis, axis, indexing='ij'), -1).reshape(-1, 3)
    squares = np.einsum('ij,ij->i', points, points)
    inside = np.flatnonzero(squares < radius * radius)
    inside = inside[np.argsort(squares[inside], kind='stable')][:GRID_POINTS]
    return points, inside, (2 * side + 1,) * 3


def _local_minima(angles, shape):
    """Return the flat indices where ``angles`` (inf outside) is no larger than 26 neighbours."""
    cube = angles.reshape(shape)
    padded = np.pad(cube, 1, constant_values=np.inf)
    lowest = np.isfinite(cube)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                if dx or dy or dz:
                    lowest &= cube <= padded[1 + dx:1 + dx + shape[0],
                                             1 + dy:1 + dy + shape[1],
                                             1 + dz:1 + dz + shape[2]]
    return np.flatnonzero(lowest.ravel())


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
        count = len(rows)
        rows = np.concatenate((rows, np.repeat(rows[:1], -count % CHUNK, axis=0)))
        finals = []
        for first in range(0, len(rows), CHUNK):
            finals.append(self.rollout.fly(rows[first:first + CHUNK])[0])
        return self.problem.residual_of(np.concatenate(finals)[:count])[:, -3:]


def _newton_all(orientation, z, step):
    """Trust-region Newton on the orientation from every row of ``z`` at once.

    Return the ends (M, 3) and their residual angles (M,). Each iteration flies every
    trial with its three differences (one flight of 4 M rows): a trial that lowers the
    angle is taken and its trust radius doubled, else the radius is quartered. It stops
    early once every angle is within SETTLED.
    """
    count = len(z)
    offsets = np.vstack((np.zeros(3), DIFFERENCE * np.eye(3)))
    radius = np.full(count, 0.5 * step)   # doubled as the first flight is taken
    angles, residual, jacobian = np.full(count, np.inf), None, None
    trial = z
    for _ in range(ITERATIONS + 1):
        flown = orientation((trial[:, None, :] + offsets).reshape(-1, 3)).reshape(count, 4, 3)
        tried = np.linalg.norm(flown[:, 0], axis=1)
        taken = tried < angles   # NaN (a failed flight) is never taken
        z = np.where(taken[:, None], trial, z)
        angles = np.where(taken, tried, angles)
        radius = np.where(taken, 2.0 * radius, 0.25 * radius)
        if residual is None:
            residual, jacobian = flown[:, 0], None
        residual = np.where(taken[:, None], flown[:, 0], residual)
        fresh = np.nan_to_num((flown[:, 1:] - flown[:, :1]).transpose(0, 2, 1) / DIFFERENCE)
        jacobian = fresh if jacobian is None else np.where(taken[:, None, None], fresh,
                                                           jacobian)
        if np.all(angles <= SETTLED):   # at T = 2 s mostly one minimum, the solution known
            break
        change = -np.einsum('kij,kj->ki', np.linalg.pinv(jacobian), np.nan_to_num(residual))
        length = np.linalg.norm(change, axis=1)
        change *= np.minimum(1.0, radius / np.maximum(length, 1e-300))[:, None]
        trial = z + change
    return z, angles


def nearer(problem, best, rollout, iterations):
    """Return ``best`` (a converged Newton) or the nearest solution the search finds.

    ``rollout``: a Rollout of CHUNK copies of the goal's body. Each polishing start gets
    ``iterations`` of the goal's Newton and is abandoned once an iterate leaves the ball.
    """
    values, shift, centre, whitening, lin = _ellipsoid(problem, best.values)
    nearest = problem.distance(best.values)
    radius = np.sqrt(max(nearest ** 2 - lin, 0.0))
    # The end orientation's rows are the residual's last three, whatever the unknowns.
    sensitivity = best.jacobian[-3:] @ shift @ np.linalg.inv(whitening.T)
    sigma = np.linalg.norm(sensitivity, 2) if np.isfinite(sensitivity).all() else np.nan
    if not (radius > 0.0 and np.isfinite(sigma) and sigma > 0.0):
        return best
    spacing = SPACING / sigma
    orientation = _Orientation(problem, rollout, values, centre, whitening)
    points, inside, shape = _grid(radius, spacing)
    angles = np.full(len(points), np.inf)
    angles[inside] = np.linalg.norm(orientation(points[inside]), axis=1)
    angles[np.isnan(angles)] = np.inf
    minima = _local_minima(angles, shape)
    minima = minima[np.argsort(np.einsum('ij,ij->i', points[minima], points[minima]),
                               kind='stable')][:MINIMA]
    if not minima.size:
        return best
    ends, angles = _newton_all(orientation, points[minima], spacing)
    reach = np.einsum('ij,ij->i', ends, ends)
    roots = np.flatnonzero((angles < ROOT) & (reach < radius ** 2))
    roots = roots[np.argsort(reach[roots], kind='stable')][:POLISHED]
    for root in roots:
        if reach[root] + lin >= nearest ** 2:
            break
        start = values(orientation.spin_at(ends[root][None]) - problem.current[-3:])[0]
        newton = Newton(problem, start)
        try:   # abandoned once an iterate leaves the ball
            newton.converge(TOLERANCE, lambda u, ball=nearest: problem.distance(u) < ball,
                            iterations)
        except NoConvergence:
            continue
        distance = problem.distance(newton.values)
        if distance < nearest * (1.0 - SAME_DISTANCE):
            best, nearest = newton, distance
    return best
