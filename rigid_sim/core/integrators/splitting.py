# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Splitting methods: kick the momenta with the wrench, drift with the free motion.

One Strang step of ``h`` is

1. half kick: ``P += F h/2``, ``L += tau h/2`` (world axes, wrench at the current state);
2. drift: ``x += h P/M`` and the torque-free rotation of every body for ``h``;
3. half kick with the wrench at the new state.

The drift is the free rigid body's exact motion for the translation and, for the rotation,
either the Dullweber-Leimkuhler-McLachlan (DLM) sequence of rotations about principal axes
(symplectic, ``|L|`` exact, energy bounded) or the closed-form flow of
:mod:`~rigid_sim.core.integrators.free_rotation`. Both work in principal axes, so a body
whose inertia is not diagonal in its own frame is turned into its principal frame and back.
The Yoshida triple jump composes three Strang steps into a fourth-order method.

A kick holds x and q fixed. When no effect depends on the momenta its force is constant
over the kick, which one evaluation integrates exactly. A damper makes the kick an ODE of
its own; one explicit step would cut the whole method to first order, so the kick is then
integrated by an explicit Runge-Kutta method of the splitting's own order.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core import rotation
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.integrators.free_rotation import TorqueFreeFlow
from rigid_sim.core.integrators.runge_kutta import CLASSICAL_RK4, EXPLICIT_MIDPOINT
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, ORIENTATION, POSITION

# Yoshida (1990) weights: w1 + w0 + w1 = 1 and w1^3 + w0^3 + w1^3 = 0 cancel the h^3 error.
YOSHIDA_OUTER = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
YOSHIDA_INNER = 1.0 - 2.0 * YOSHIDA_OUTER
# Unit vectors e_1, e_2, e_3 as (3, 1) columns that broadcast over N bodies.
AXIS_ROWS = np.eye(3)[:, :, None]
MOMENTA = slice(LINEAR_MOMENTUM.start, ANGULAR_MOMENTUM.stop)   # rows of [P, L], as [F, tau]


def dlm_rotation(moments, body_l, orientation, h):
    """Free rotation for ``h`` as rotations about principal axes 1, 2, 3, 2, 1 (DLM 1997).

    Each sub-flow keeps ``T_i = L_i^2 / 2 I_i``: ``L_b`` turns by ``-theta`` and ``q`` by
    ``+theta`` about axis i, ``theta = L_i t / I_i``. Symmetric composition: order 2.

    Parameters
    ----------
    moments : (N, 3) float
        Principal moments, kg m^2.
    body_l : (N, 3) float
        Angular momentum in principal axes, kg m^2/s.
    orientation : (N, 4) float
        Quaternions (x, y, z, w), principal axes to world.
    h : float
        Step, s.

    Returns
    -------
    body_l : (N, 3) float
        Angular momentum in principal axes after ``h``.
    orientation : (N, 4) float
        Orientation after ``h``.
    """
    body_l, orientation = dlm_rotation_rows(np.asarray(moments).T, np.array(body_l).T,
                                            np.array(orientation).T, h)
    return body_l.T, orientation.T


def dlm_rotation_rows(moments, body_l, orientation, h):
    """:func:`dlm_rotation` on component-major rows, (3, N), (3, N), (4, N), in place."""
    for axis, fraction in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        theta = (fraction * h) * body_l[axis] / moments[axis]
        after, before = (axis + 1) % 3, (axis + 2) % 3
        # L_b turns by -theta about the axis: a plane rotation of the other two components.
        cos, sin = np.cos(theta), np.sin(theta)
        l_after = body_l[after] * cos + body_l[before] * sin
        body_l[before] = body_l[before] * cos - body_l[after] * sin
        body_l[after] = l_after
        # q <- q (sin(theta/2) e, cos(theta/2)) = cos q + sin q (e, 0).
        half = 0.5 * theta
        turned = rotation.times_pure_rows(orientation, AXIS_ROWS[axis] * np.sin(half))
        orientation *= np.cos(half)
        orientation += turned
    return body_l, orientation


class StrangSplitting(Integrator):
    """Kick-drift-kick with a free-rotation drift; subclasses choose the drift."""

    order = 2
    weights = (1.0,)   # sub-step fractions; the Yoshida variants use three
    kick_tableau = EXPLICIT_MIDPOINT  # for momentum-dependent kicks, of the method's order

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        moments, body_from_principal = self.bodies.principal_moments
        self._moments = moments
        self._moment_rows = np.ascontiguousarray(moments.T)
        self._principal = Rotation.from_matrix(body_from_principal).as_quat().T.copy()
        self._principal_inverse = self._principal * np.array([[-1.0], [-1.0], [-1.0], [1.0]])
        # Bodies whose frames are already principal (diagonal inertia, sorted) skip two
        # quaternion products per drift; multiplying by the identity would change no bit.
        self._principal_is_body = bool(np.all(self._principal == np.array([[0.0], [0.0], [0.0],
                                                                           [1.0]])))

    def _step_impl(self, rows, time, dt):
        # Adjacent half kicks of consecutive sub-steps act at the same state and time, so
        # they merge: a composition of k Strang steps costs k + 1 wrench evaluations.
        rows = np.array(rows, order='C')
        kick = 0.5 * self.weights[0]
        following = self.weights[1:] + (0.0,)
        for weight, next_weight in zip(self.weights, following):
            self._kick(rows, time, kick * dt)
            self._drift(rows, weight * dt)
            time += weight * dt
            kick = 0.5 * (weight + next_weight)
        self._kick(rows, time, kick * dt)
        return rows

    def _kick(self, rows, time, h):
        """Momenta after ``h`` of the wrench at fixed x and q, in place."""
        if not self.system.velocity_dependent:
            self.wrench_rows(rows, time)
            rows[MOMENTA] += h * self._wrench
            return
        start = rows[MOMENTA].copy()
        tableau = self.kick_tableau
        slopes = np.empty((len(tableau.b),) + start.shape)
        for stage, row in enumerate(tableau.a):
            rows[MOMENTA] = start + sum(h * w * s for w, s in zip(row, slopes) if w)
            self.wrench_rows(rows, time)
            slopes[stage] = self._wrench
        rows[MOMENTA] = start + np.einsum('s,sin->in', h * np.asarray(tableau.b), slopes)

    def _drift(self, rows, h):
        """Free motion for ``h``: straight-line translation and torque-free rotation."""
        rows[POSITION] += rows[LINEAR_MOMENTUM] * (h * self.bodies.inverse_mass)
        principal_q = rows[ORIENTATION]
        if not self._principal_is_body:
            principal_q = rotation.multiply_rows(principal_q, self._principal)
        matrices = rotation.matrix_rows(principal_q)
        principal_l = rotation.rotate_inverse_rows(matrices, rows[ANGULAR_MOMENTUM])
        principal_l, principal_q = self._free_rotation_rows(principal_l, principal_q, h)
        rotation.rotate_rows(rotation.matrix_rows(principal_q), principal_l,
                             out=rows[ANGULAR_MOMENTUM])
        if not self._principal_is_body:
            principal_q = rotation.multiply_rows(principal_q, self._principal_inverse)
        rows[ORIENTATION] = principal_q

    def _free_rotation_rows(self, principal_l, principal_q, h):
        """Torque-free rotation of rows (3, N) and (4, N) for ``h``."""
        raise NotImplementedError


class DLM(StrangSplitting):
    """Dullweber-Leimkuhler-McLachlan splitting. Order 2; two wrench evaluations (four damped).

    Symplectic and time-reversible: ``|L|`` of a torque-free body is exact to round-off and
    its energy error stays bounded (no drift) at any step; accurate up to ``|omega| dt ~ 1``.
    """

    name = 'dlm'

    def _free_rotation_rows(self, principal_l, principal_q, h):
        return dlm_rotation_rows(self._moment_rows, principal_l, principal_q, h)


class DLM4(DLM):
    """DLM composed by the Yoshida triple jump. Order 4; four wrench evaluations (16 damped).

    Keeps DLM's exact ``|L|`` and bounded energy; one inner sub-step runs backwards.
    """

    name = 'dlm4'
    order = 4
    weights = (YOSHIDA_OUTER, YOSHIDA_INNER, YOSHIDA_OUTER)
    kick_tableau = CLASSICAL_RK4


class ExactSplit(StrangSplitting):
    """Torque kicks around the exact free rotation (Jacobi elliptic flow). Order 2.

    A body no effect torques moves exactly (to ~1e-11) at any step: the scene calls for
    no torque, so none is integrated. With torques the error is O(dt^2) per unit time and
    ``|L|`` changes only through the kicks.
    """

    name = 'exact_split'

    def __init__(self, system, tolerance=1e-6):
        super().__init__(system, tolerance)
        self._flow = TorqueFreeFlow(self._moments)

    def _free_rotation_rows(self, principal_l, principal_q, h):
        principal_l, principal_q = self._flow(principal_l.T, principal_q.T, h)
        return principal_l.T, principal_q.T


class ExactSplit4(ExactSplit):
    """The exact-flow splitting composed by the Yoshida triple jump. Order 4."""

    name = 'exact_split4'
    order = 4
    weights = (YOSHIDA_OUTER, YOSHIDA_INNER, YOSHIDA_OUTER)
    kick_tableau = CLASSICAL_RK4
