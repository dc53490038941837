# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Deflation: a goal's equations with its known solutions taken out.

The branch walk (:meth:`GoalSolver._nearest <rigid_sim.core.goals.GoalSolver._nearest>`)
finds the solutions a whole turn apart; an asymmetric body's other solutions are not a
whole turn about any axis it tries, and two of them may be near ties by the metric. Newton
from the current motion would often converge to one already found. Deflation (Farrell,
Birkisson and Funke, SIAM J. Sci. Comput. 37, 2015) multiplies the residual by
``prod_k (1 / |u - u_k|^POWER + SHIFT)`` over the known solutions ``u_k``: the product
grows without bound at each of them, so they are no longer roots, and is at least 1
(``SHIFT``), so a deflated residual within the tolerance is a true residual within it,
and far from the known solutions the equations are the goal's own. The distance is the
solver's metric of "nearest" (:meth:`GoalProblem.distance
<rigid_sim.core.goal_problem.GoalProblem.distance>`).
"""
import numpy as np

POWER = 2.0
SHIFT = 1.0


class Deflated:
    """The equations of ``problem`` (a GoalProblem) less the solutions ``roots`` [(n,)].

    Stands in for the problem in :class:`~rigid_sim.core.goal_newton.Newton`: its
    residuals, differences' steps, scale and stopping test.
    """

    def __init__(self, problem, roots):
        self.problem = problem
        self.roots = [np.array(root, dtype=float) for root in roots]
        self.steps, self.scale, self.fresh = problem.steps, problem.scale, problem.fresh

    def factor(self, values):
        """Return the deflation (K,) of unknowns (K, n): at least 1, unbounded at a root."""
        factor = np.ones(len(values))
        for root in self.roots:
            change = values - root   # by the metric of a change of the unknowns
            squares = np.einsum('ki,ij,kj->k', change, self.problem.metric, change)
            distance = np.sqrt(np.maximum(squares, 0.0))
            with np.errstate(divide='ignore'):
                factor *= 1.0 / distance ** POWER + SHIFT
        return factor

    def residuals(self, values):
        """Residuals (K, m) of unknowns (K, n), deflated; NaN rows for failed flights.

        At a known root itself (0 times an unbounded factor) the row is NaN too: Newton
        treats it as a failed flight, which keeps it off the root deflation takes out.
        """
        with np.errstate(invalid='ignore'):
            return self.problem.residuals(values) * self.factor(values)[:, None]

    def close_enough(self, residual, tolerance):
        """Whether the deflated ``residual`` is within ``tolerance``: then the true one is."""
        return self.problem.close_enough(residual, tolerance)
