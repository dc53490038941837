# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Pseudo-arclength continuation: the current motion followed to the goal through folds.

The current motion reaches where its own flight ends. Aim the residual at a pose a
fraction ``s`` of the way from there to the goal (position on the line, orientation on the
shortest turn): the solutions ``u(s)`` form a curve from the current motion (s = 0) that,
for a reachable goal, generically reaches s = 1. Over a long flight that curve turns back
in ``s`` (a fold: the end pose stops moving one way as the spin grows), where stepping
``s`` forward, as natural continuation does, finds nothing. Pseudo-arclength continuation
(Keller) follows the curve by its length in (u, s) instead: predict along the tangent (the
null vector of the Jacobian in (u, s)), correct by Newton on the residual plus the
condition that the correction is normal to the tangent. Unknowns are scaled to the
displacement they make at the goal's time and ``s`` to the gap's size, so the curve's
length is in metres and radians.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core.goal_newton import NoConvergence

FIRST_STEP = 0.05     # m or rad along the curve
LARGEST_STEP = 2.0
SMALLEST_STEP = 1e-3
CORRECTIONS = 4       # Newton corrections of one step at most
CORRECTED = 1e-6      # m and rad: close enough to the curve
GROWTH = 1.5          # of the step after a correction of at most two iterations
MAX_STEPS = 400        # predictor steps, taken or refused
FRACTION_STEP = 1e-7  # of s: the difference of the aim
# Flights of the n + 1 copies a continuation may fly: the first point, then every step's
# corrections and the point each ends on.
WORST_FLIGHTS = 1 + MAX_STEPS * (CORRECTIONS + 1)


class Arclength:
    """Follows the solutions of ``problem`` (a GoalProblem, flown on its current flight)."""

    def __init__(self, problem):
        self.problem = problem
        self.flights = 0   # each of the n + 1 copies
        self._end, self._turn = problem.current_end()
        position, orientation = problem.goal_pose
        self._gap = position - self._end
        self._twist = (Rotation.from_quat(orientation) * self._turn.inv()).as_rotvec()
        self.length = max(float(np.hypot(np.linalg.norm(self._gap),
                                         np.linalg.norm(self._twist))), 1e-12)
        self.scale = np.append(problem.scale, self.length)
        self._offsets = np.vstack((np.zeros(problem.count), np.diag(problem.steps)))

    def _aim(self, fraction):
        """Aim the problem at the pose ``fraction`` of the way (any real number)."""
        self.problem.aim_at(self._end + fraction * self._gap,
                            (Rotation.from_rotvec(fraction * self._twist)
                             * self._turn).as_quat())

    def _system(self, x):
        """Residual (m,) and Jacobian (m, n + 1) at scaled ``x`` (u scale, s length)."""
        problem = self.problem
        values, fraction = x[:-1] / self.scale[:-1], x[-1] / self.length
        rows = values + self._offsets
        final, _ = problem.batch.fly(problem.start_rows(rows), rows if problem.wrench else None)
        self.flights += 1
        self._aim(fraction)
        residuals = problem.residual_of(final)
        self._aim(fraction + FRACTION_STEP)
        moved = problem.residual_of(final[:1])[0]
        jacobian = np.column_stack(((residuals[1:] - residuals[0]).T / problem.steps,
                                    (moved - residuals[0]) / FRACTION_STEP))
        return residuals[0], jacobian / self.scale

    @staticmethod
    def _tangent(jacobian, before):
        """Return the unit null vector of ``jacobian`` (m, n + 1) on the side of ``before``."""
        tangent = np.linalg.svd(jacobian)[2][-1]
        return tangent if tangent @ before >= 0.0 else -tangent

    def _correct(self, x, tangent):
        """Newton onto the curve from ``x``, normal to ``tangent``: (x, r, J, its) or None."""
        anchor = x.copy()
        for iteration in range(CORRECTIONS + 1):
            residual, jacobian = self._system(x)
            if not np.isfinite(residual).all() or not np.isfinite(jacobian).all():
                return None
            if self.problem.close_enough(residual, CORRECTED):
                return x, residual, jacobian, iteration
            if iteration == CORRECTIONS:
                return None
            bordered = np.vstack((jacobian, tangent))
            right = np.append(-residual, -(x - anchor) @ tangent)
            try:
                x = x + np.linalg.solve(bordered, right)
            except np.linalg.LinAlgError:
                return None
        return None

    def follow(self):
        """Return the unknowns (n,) where the curve crosses s = 1, to CORRECTED.

        NoConvergence when the step shrinks below SMALLEST_STEP or MAX_STEPS are taken
        before the curve gets there.
        """
        problem = self.problem
        x = np.append(problem.current * self.scale[:-1], 0.0)
        residual, jacobian = self._system(x)
        before = np.zeros(x.size)
        before[-1] = 1.0
        tangent = self._tangent(jacobian, before)
        step = FIRST_STEP
        try:
            for _ in range(MAX_STEPS):
                corrected = self._correct(x + step * tangent, tangent)
                if corrected is None:
                    step /= 2.0
                    if step < SMALLEST_STEP:
                        break
                    continue
                x_new, residual, jacobian, iterations = corrected
                if x_new[-1] >= self.length:   # crossed s = 1: the secant's point there
                    between = (self.length - x[-1]) / (x_new[-1] - x[-1])
                    return (x + between * (x_new - x))[:-1] / self.scale[:-1]
                tangent = self._tangent(jacobian, x_new - x)
                x = x_new
                if iterations <= 2:
                    step = min(LARGEST_STEP, GROWTH * step)
        finally:
            problem.aim_at(*problem.goal_pose)
        raise NoConvergence(f'the continuation stopped {x[-1] / self.length:.3g} of the way '
                            f'to the goal')
