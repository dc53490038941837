# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A grid over the ball of spins a nearer solution must lie in; its minima; Newton from all.

The pieces the searches of the ball share (:mod:`~rigid_sim.core.goal_ball` where a flight
is one exact step, :mod:`~rigid_sim.core.goal_coupled_ball` where a spring couples the
centre of mass's motion to the spin): the ball's coordinates by the metric of "nearest",
a grid over it nearest points first, the grid points whose residual is a local minimum,
and a trust-region Newton run from all of them at once, its flights batched as rows.
"""
import numpy as np

from rigid_sim.core.goal_newton import Newton, NoConvergence
from rigid_sim.core.goal_problem import SAME_DISTANCE, TOLERANCE

DIFFERENCE = 1e-6   # the batched Newton's forward differences' step (whitened units)


def ellipsoid(problem, best):
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


def grid(radius, spacing, cap):
    """Return grid points (P, 3), the indices of those within ``radius``, (side,) * 3.

    The indices nearest first, at most ``cap``: the ball is cut to the radius that holds
    about that many.
    """
    held = spacing * (0.75 * cap / np.pi) ** (1.0 / 3.0)
    side = int(np.ceil(min(radius, held) / spacing))
    axis = np.arange(-side, side + 1) * spacing
    points = np.stack(np.meshgrid(axis, axis, axis, indexing='ij'), -1).reshape(-1, 3)
    squares = np.einsum('ij,ij->i', points, points)
    inside = np.flatnonzero(squares < radius * radius)
    inside = inside[np.argsort(squares[inside], kind='stable')][:cap]
    return points, inside, (2 * side + 1,) * 3


def local_minima(sizes, shape):
    """Return the flat indices where ``sizes`` (inf outside) is no larger than 26 neighbours."""
    cube = sizes.reshape(shape)
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


def nearest_minima(points, sizes, shape, cap):
    """Return the local minima's flat indices, nearest the grid's centre first, at most ``cap``."""
    minima = local_minima(sizes, shape)
    return minima[np.argsort(np.einsum('ij,ij->i', points[minima], points[minima]),
                             kind='stable')][:cap]


def newton_all(evaluate, z, step, iterations, settled):
    """Trust-region Newton on ``evaluate`` ((K, n) -> (K, n) residuals) from every row of ``z``.

    Return the ends (M, n), their residuals' norms (M,) and Jacobians (M, n, n). Each
    iteration flies every trial with its n differences (one call of (n + 1) M rows): a
    trial that lowers the residual is taken and its trust radius doubled, else the radius
    is quartered (the first radius is half ``step``). It stops early once every residual
    is within ``settled``.
    """
    count, size = z.shape
    offsets = np.vstack((np.zeros(size), DIFFERENCE * np.eye(size)))
    radius = np.full(count, 0.5 * step)   # doubled as the first flight is taken
    norms, residual, jacobian = np.full(count, np.inf), None, None
    trial = z
    for _ in range(iterations + 1):
        flown = evaluate((trial[:, None, :] + offsets).reshape(-1, size)).reshape(
            count, size + 1, size)
        tried = np.linalg.norm(flown[:, 0], axis=1)
        taken = tried < norms   # NaN (a failed flight) is never taken
        z = np.where(taken[:, None], trial, z)
        norms = np.where(taken, tried, norms)
        radius = np.where(taken, 2.0 * radius, 0.25 * radius)
        if residual is None:
            residual = flown[:, 0]
        residual = np.where(taken[:, None], flown[:, 0], residual)
        fresh = np.nan_to_num((flown[:, 1:] - flown[:, :1]).transpose(0, 2, 1) / DIFFERENCE)
        jacobian = fresh if jacobian is None else np.where(taken[:, None, None], fresh,
                                                           jacobian)
        if np.all(norms <= settled):   # at T = 2 s mostly one minimum, the solution known
            break
        change = -np.einsum('kij,kj->ki', np.linalg.pinv(jacobian), np.nan_to_num(residual))
        length = np.linalg.norm(change, axis=1)
        change *= np.minimum(1.0, radius / np.maximum(length, 1e-300))[:, None]
        trial = z + change
    return z, norms, jacobian


def fly_padded(rollout, rows):
    """Return the final states of ``rows`` (K, 13), at most the rollout's copies, in one call.

    The call flies all of its copies: the rows left over are the first row again, their
    flights dropped (each copy flies on its own).
    """
    padded = np.concatenate((rows, np.repeat(rows[:1], rollout.copies.copies - len(rows),
                                             axis=0)))
    return rollout.fly(padded)[0][:len(rows)]


def polished(problem, best, nearest, roots, iterations, beyond=0.0):
    """Polish ``roots`` by the goal's own Newton, nearest first; the nearest solution found.

    ``roots``: (reach, start (n,), Jacobian or None) in increasing ``reach``, the squared
    distance the root's start predicts less ``beyond``; the polishing stops at the first
    one predicted no nearer than the nearest so far. A Newton is abandoned once an iterate
    leaves the ball of that distance, so the solution returned is never farther than
    ``best`` (at ``nearest``).
    """
    for reach, start, jacobian in roots:
        if reach + beyond >= nearest ** 2:
            break
        newton = Newton(problem, start, jacobian)
        try:
            newton.converge(TOLERANCE, lambda u, ball=nearest: problem.distance(u) < ball,
                            iterations)
        except NoConvergence:
            continue
        distance = problem.distance(newton.values)
        if distance < nearest * (1.0 - SAME_DISTANCE):
            best, nearest = newton, distance
    return best
