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
from rigid_sim.core.integrators.free_rotation import torque_free_flow
from rigid_sim.core.integrators.runge_kutta import CLASSICAL_RK4, EXPLICIT_MIDPOINT
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, ORIENTATION, POSITION

# Yoshida (1990) weights: w1 + w0 + w1 = 1 and w1^3 + w0^3 + w1^3 = 0 cancel the h^3 error.
YOSHIDA_OUTER = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
YOSHIDA_INNER = 1.0 - 2.0 * YOSHIDA_OUTER
AXES = np.eye(3)


def dlm_rotation(moments, body_l, orientation, h):
    """Free rotation for ``h`` as rotations about principal axes 1, 2, 3, 2, 1 (DLM 1997).

    Each sub-flow keeps ``T_i = L_i^2 / 2 I_i``: ``L_b`` turns by ``-theta`` and ``q`` by
    ``+theta`` about axis i, ``theta = L_i t / I_i``. Symmetric composition: order 2.

    Parameters
    ----------
    moments : (N, 3) principal moments, kg m^2
    body_l : (N, 3) angular momentum in principal axes
    orientation : (N, 4) (x, y, z, w), principal axes to world
    h : float, s
    """
    for axis, fraction in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        theta = fraction * h * body_l[:, axis] / moments[:, axis]
        turn = rotation.exp_map(theta[:, None] * AXES[axis])
        orientation = rotation.multiply(orientation, turn)
        body_l = rotation.rotate_inverse(rotation.to_matrix(turn), body_l)
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
        self._principal = Rotation.from_matrix(body_from_principal).as_quat()

    def _step_impl(self, y, time, dt):
        # Adjacent half kicks of consecutive sub-steps act at the same state and time, so
        # they merge: a composition of k Strang steps costs k + 1 wrench evaluations.
        y = y.copy()
        kick = 0.5 * self.weights[0]
        following = self.weights[1:] + (0.0,)
        for weight, next_weight in zip(self.weights, following):
            self._kick(y, time, kick * dt)
            self._drift(y, weight * dt)
            time += weight * dt
            kick = 0.5 * (weight + next_weight)
        self._kick(y, time, kick * dt)
        return y

    def _kick(self, y, time, h):
        """Momenta after ``h`` of the wrench at fixed x and q, in place."""
        if not self.system.velocity_dependent:
            force, torque = self.wrench(y, time)
            y[:, LINEAR_MOMENTUM] += h * force
            y[:, ANGULAR_MOMENTUM] += h * torque
            return
        momenta = slice(LINEAR_MOMENTUM.start, ANGULAR_MOMENTUM.stop)
        start = y[:, momenta].copy()
        slopes = []
        for row in self.kick_tableau.a:
            y[:, momenta] = start + sum(h * w * s for w, s in zip(row, slopes) if w)
            slopes.append(np.concatenate(self.wrench(y, time), axis=1))
        y[:, momenta] = start + sum(h * w * s for w, s in zip(self.kick_tableau.b, slopes))

    def _drift(self, y, h):
        """Free motion for ``h``: straight-line translation and torque-free rotation."""
        y[:, POSITION] += h * y[:, LINEAR_MOMENTUM] / self.bodies.mass[:, None]
        principal_q = rotation.multiply(y[:, ORIENTATION], self._principal)
        world_from_principal = rotation.to_matrix(principal_q)
        principal_l = rotation.rotate_inverse(world_from_principal, y[:, ANGULAR_MOMENTUM])
        principal_l, principal_q = self.free_rotation(self._moments, principal_l, principal_q, h)
        y[:, ANGULAR_MOMENTUM] = rotation.rotate(rotation.to_matrix(principal_q), principal_l)
        y[:, ORIENTATION] = rotation.multiply(principal_q, rotation.conjugate(self._principal))


class DLM(StrangSplitting):
    """Dullweber-Leimkuhler-McLachlan splitting. Order 2, two wrench evaluations (four with dampers).

    Symplectic and time-reversible: ``|L|`` of a torque-free body is exact to round-off and
    its energy error stays bounded (no drift) at any step; accurate up to ``|omega| dt ~ 1``.
    """

    name = 'dlm'
    free_rotation = staticmethod(dlm_rotation)


class DLM4(DLM):
    """DLM composed by the Yoshida triple jump. Order 4, four wrench evaluations (sixteen with dampers).

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
    free_rotation = staticmethod(torque_free_flow)


class ExactSplit4(ExactSplit):
    """The exact-flow splitting composed by the Yoshida triple jump. Order 4."""

    name = 'exact_split4'
    order = 4
    weights = (YOSHIDA_OUTER, YOSHIDA_INNER, YOSHIDA_OUTER)
    kick_tableau = CLASSICAL_RK4
