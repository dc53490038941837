# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Newton's method for a goal's unknowns, damped by Levenberg-Marquardt, with Broyden.

The Jacobian comes from forward differences, every perturbed flight a copy in one compiled
call (``problem.residuals`` of n + 1 rows). When that call is cheap it is made at every
iterate (the trial's Jacobian comes with its residual); when it is dear, trials fly one
copy and the Jacobian is kept up to date by Broyden's rank-one update, taken afresh only
when a step leaves more than :data:`STALE` of the residual. Steps are Newton's while they
reduce the residual as the linear model predicts; otherwise they are damped towards the
gradient (Levenberg-Marquardt, Nielsen's update of the damping), so the iterates stay near
the first, which the solver picks near the current motion.
"""
import numpy as np

from rigid_sim.core.goal_flight import GoalRefused

MAX_ITERATIONS = 40
RATIO = 1e-4            # of the predicted decrease a step must achieve to be taken
FIRST_DAMPING = 1e-3    # of the normal matrix's diagonal, after a refused Newton step
SMALLEST_DAMPING = 1e-9   # below which a taken step makes the next one Newton's again
LARGEST_DAMPING = 1e8   # beyond which no step reduces the residual
STALE = 0.25            # Broyden's Jacobian is renewed after a step that leaves more


class NoConvergence(GoalRefused):
    """The iterations did not reach the goal."""


class LeftTheBound(NoConvergence):
    """The iterates left the region where a solution was sought."""


class Newton:
    """Iterates on ``problem`` from the unknowns ``start`` (n,), optionally with a Jacobian.

    ``problem`` provides ``residuals(U)`` ((K, n) -> (K, m), NaN rows for flights that
    failed), ``steps`` (n,) of the differences, ``scale`` (n,) (the displacement a unit of
    each unknown makes, for the condition number), ``fresh`` (bool: renew the Jacobian at
    every iterate) and ``close_enough(r, tolerance)``.
    """

    def __init__(self, problem, start, jacobian=None):
        self.problem = problem
        self.values = np.array(start, dtype=float)
        self.jacobian = None if jacobian is None else np.array(jacobian, dtype=float)
        self.residual = None
        self.iterations = 0
        self.damping = 0.0   # Levenberg-Marquardt's, relative to the normal matrix diagonal
        self._growth = 2.0   # of the damping after the next refused step
        self._steps = problem.steps
        self._offsets = np.vstack((np.zeros_like(self._steps), np.diag(self._steps)))

    def differences(self, values):
        """Residual (m,) and forward-difference Jacobian (m, n) at ``values``: one flight."""
        steps = self._steps
        residuals = self.problem.residuals(values + self._offsets)
        return residuals[0], (residuals[1:] - residuals[0]).T / steps

    def converge(self, tolerance, bound=None, iterations=MAX_ITERATIONS):
        """Iterate until ``close_enough(residual, tolerance)``; the unknowns and iterations.

        Raises NoConvergence after ``iterations`` more, or when no step reduces the
        residual; LeftTheBound when ``bound(values)`` is false at an iterate.
        """
        limit = self.iterations + iterations
        if self.residual is None:
            if self.jacobian is None:
                self.residual, self.jacobian = self.differences(self.values)
            else:
                self.residual = self.problem.residuals(self.values[None])[0]
        if not np.isfinite(self.residual).all():
            raise NoConvergence('the flight from the first iterate is not finite')
        while not self.problem.close_enough(self.residual, tolerance):
            if self.iterations >= limit:
                raise NoConvergence(f'no convergence in {self.iterations} iterations: '
                                    f'{self.describe()}')
            self._step()
            if bound is not None and not bound(self.values):
                raise LeftTheBound(f'the iterates left the region sought: {self.describe()}')
        return self.values, self.iterations

    def describe(self):
        """Return the residual in words."""
        return f'residual {np.linalg.norm(self.residual):.3g} (m and rad)'

    def condition(self):
        """Condition number of the Jacobian with unknowns scaled to their displacements."""
        return float(np.linalg.cond(self.jacobian * self.problem.scale))

    def _step(self):
        """One Levenberg-Marquardt step: Newton's while it works, damped when it does not."""
        size = self.residual @ self.residual
        renewed = self.problem.fresh
        while True:
            try:
                change = self._change()
            except np.linalg.LinAlgError:
                raise NoConvergence(f'the unknowns cannot move the body towards the goal '
                                    f'(singular Jacobian, {self.describe()})') from None
            trial = self.values + change
            if self.problem.fresh:
                residual, jacobian = self.differences(trial)
            else:
                residual, jacobian = self.problem.residuals(trial[None])[0], None
            linear = self.residual + self.jacobian @ change
            predicted = size - linear @ linear
            actual = residual @ residual if np.isfinite(residual).all() else np.inf
            if predicted > 0.0 and size - actual > RATIO * predicted:
                # Nielsen's update: less damping the better the linear model predicted.
                ratio = (size - actual) / predicted
                self.damping *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
                self.damping *= self.damping >= SMALLEST_DAMPING
                self._growth = 2.0
                break
            self.damping = max(self._growth * self.damping, FIRST_DAMPING)
            self._growth *= 2.0
            if self.damping > LARGEST_DAMPING:
                if renewed:
                    raise NoConvergence(f'no step reduces the {self.describe()}')
                # Broyden's Jacobian may have drifted: renew it here and search again.
                self.residual, self.jacobian = self.differences(self.values)
                self.damping, self._growth, renewed = 0.0, 2.0, True
        if jacobian is None:
            jacobian = self.jacobian + np.outer(
                residual - self.residual - self.jacobian @ change, change) / (change @ change)
            if actual > STALE ** 2 * size:
                residual, jacobian = self.differences(trial)
        self.values, self.residual, self.jacobian = trial, residual, jacobian
        self.iterations += 1

    def _change(self):
        """Newton's step, or Levenberg-Marquardt's with the damping (LinAlgError: singular)."""
        if not self.damping:
            return np.linalg.solve(self.jacobian, -self.residual)
        normal = self.jacobian.T @ self.jacobian
        damped = normal + self.damping * np.diag(np.diag(normal))
        return np.linalg.solve(damped, -self.jacobian.T @ self.residual)

    def chord(self, residual):
        """Step once against ``residual`` (m,), the world's own flight's, with this Jacobian."""
        self.values = self.values + np.linalg.solve(self.jacobian, -residual)
        self.residual = None
        self.iterations += 1
