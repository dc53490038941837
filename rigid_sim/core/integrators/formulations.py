# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""What a Runge-Kutta method differentiates: Baraff's world momenta or body-axes momenta.

Both describe the same motion. They differ in how an orientation error propagates: with
Baraff's world-axes ``L``, ``omega = R I_body^-1 R^T L`` depends on ``q``, so every error in
``q`` feeds back into ``omega`` and grows. With the body-axes ``L_b = R^T L``,
``omega_b = I_body^-1 L_b`` does not depend on ``q`` at all (Euler's equations). Measured
near the intermediate axis, RK4 is 1000-2500x more accurate at the same step in body axes
(docs/accuracy.md). The public state stays Baraff's; only the inside
of a step changes.

A formulation is built per integrator and owns the buffers of its stages: the integrator
writes a stage state into ``state`` (13, N) and calls ``slope(time, out)``. States are
component-major (see :mod:`~rigid_sim.core.integrators.base`).
"""
import numpy as np

from rigid_sim.core import rotation
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, ORIENTATION, POSITION


class Workspace:
    """Scratch rows reused by every stage: at large N a fresh temporary costs page faults.

    ``matrices`` (3, 3, N) holds the stage's ``R``; the rest is scratch for
    :mod:`~rigid_sim.core.rotation`'s row functions.
    """

    def __init__(self, count):
        self.matrices = np.empty((3, 3, count))
        self.matrix_work = np.empty((25, count))
        self.vectors = np.empty((3, 3, count))      # omega, R^T tau, a cross product
        self.cross_work = np.empty((6, count))
        self.quaternion_work = np.empty((4, 3, count))

    def rotation(self, q):
        """``R`` (3, 3, N) of quaternion rows ``q`` (4, N), in ``matrices``."""
        return rotation.matrix_rows(q, out=self.matrices, work=self.matrix_work)


class WorldMomentum:
    """Baraff's state: ``d/dt [x, q, P, L] = [P/M, (omega, 0) q / 2, F, tau]``."""

    def __init__(self, integrator):
        self._integrator = integrator
        self._bodies = integrator.bodies
        self._work = Workspace(self._bodies.count)
        self.state = np.empty((13, self._bodies.count))   # the stage ``slope`` differentiates
        self.start = np.empty_like(self.state)            # the state at the step's start

    def to_internal(self, rows):
        """Copy public rows (13, N) into ``start``; here the same layout."""
        self.start[...] = rows
        return self.start

    def to_public(self, z):
        """Return new public rows (13, N) of an internal state."""
        return z.copy()

    def slope(self, time, out):
        """``d/dt state`` at ``time`` into ``out`` (13, N); returns ``out``."""
        z, bodies, work = self.state, self._bodies, self._work
        matrices = work.rotation(z[ORIENTATION])
        force, torque = self._integrator.wrench_rows(z, time, matrices)
        body_l, omega = work.vectors[0], work.vectors[1]
        rotation.rotate_inverse_rows(matrices, z[ANGULAR_MOMENTUM], out=body_l)
        rotation.rotate_rows(bodies.inertia_body_inv_rows, body_l, out=work.vectors[2])
        rotation.rotate_rows(matrices, work.vectors[2], out=omega)
        np.multiply(z[LINEAR_MOMENTUM], bodies.inverse_mass, out=out[POSITION])
        rotation.pure_times_rows(omega, z[ORIENTATION], out=out[ORIENTATION],
                                 work=work.quaternion_work)
        out[ORIENTATION] *= 0.5
        out[LINEAR_MOMENTUM] = force
        out[ANGULAR_MOMENTUM] = torque
        return out


# Internal rows of BodyMomentum: body-axes L first, then x, q, P at their public rows + 3, so
# rows 3:16 of its buffer are the world-axes state [x, q, P, L] the effects see, with no copy.
INNER_L = slice(0, 3)
_SHIFT = 3
INNER_X = slice(POSITION.start + _SHIFT, POSITION.stop + _SHIFT)
INNER_Q = slice(ORIENTATION.start + _SHIFT, ORIENTATION.stop + _SHIFT)
INNER_P = slice(LINEAR_MOMENTUM.start + _SHIFT, LINEAR_MOMENTUM.stop + _SHIFT)


class BodyMomentum:
    """Body-axes momentum: ``d/dt L_b = R^T tau - omega_b x L_b``, ``dq/dt = q (omega_b, 0)/2``.

    Internal rows: ``[L_b, x, q, P]`` (13, N).
    """

    def __init__(self, integrator):
        self._integrator = integrator
        self._bodies = integrator.bodies
        self._work = Workspace(self._bodies.count)
        self._buffer = np.empty((16, self._bodies.count))
        self.state = self._buffer[:13]     # [L_b, x, q, P], the stage ``slope`` differentiates
        self._world = self._buffer[3:]     # [x, q, P, L]: the same stage in world axes
        self.start = np.empty_like(self.state)   # the state at the step's start

    def to_internal(self, rows):
        """Return the internal state of public rows (13, N), written into ``start``."""
        z = self.start
        z[_SHIFT:] = rows[:ANGULAR_MOMENTUM.start]
        matrices = self._work.rotation(rows[ORIENTATION])
        rotation.rotate_inverse_rows(matrices, rows[ANGULAR_MOMENTUM], out=z[INNER_L])
        return z

    def to_public(self, z):
        """Return new public rows (13, N) of an internal state (orientation made unit first)."""
        rows = np.empty_like(z)
        rows[:ANGULAR_MOMENTUM.start] = z[_SHIFT:]
        rotation.normalize_rows(rows[ORIENTATION], out=rows[ORIENTATION])
        matrices = self._work.rotation(rows[ORIENTATION])
        rotation.rotate_rows(matrices, z[INNER_L], out=rows[ANGULAR_MOMENTUM])
        return rows

    def slope(self, time, out):
        """``d/dt state`` at ``time`` into ``out`` (13, N); returns ``out``."""
        z, bodies, work = self.state, self._bodies, self._work
        body_l = z[INNER_L]
        matrices = work.rotation(z[INNER_Q])
        force, torque = self._integrator.wrench_rows(self._world, time, matrices,
                                                     self._world_momentum)
        body_omega, gyroscopic = work.vectors[0], work.vectors[1]
        rotation.rotate_rows(bodies.inertia_body_inv_rows, body_l, out=body_omega)
        np.multiply(z[INNER_P], bodies.inverse_mass, out=out[INNER_X])
        rotation.times_pure_rows(z[INNER_Q], body_omega, out=out[INNER_Q],
                                 work=work.quaternion_work)
        out[INNER_Q] *= 0.5
        out[INNER_P] = force
        rotation.rotate_inverse_rows(matrices, torque, out=out[INNER_L])
        # L_b x omega_b = -omega_b x L_b
        rotation.cross_rows(body_l, body_omega, out=gyroscopic, work=work.cross_work)
        out[INNER_L] += gyroscopic
        return out

    def _world_momentum(self):
        """Fill the world-axes L of the stage: only when an effect reads the momenta."""
        rotation.rotate_rows(self._work.matrices, self.state[INNER_L],
                             out=self._world[ANGULAR_MOMENTUM])
