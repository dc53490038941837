"""What a Runge-Kutta method differentiates: Baraff's world momenta or body-axes momenta.

Both describe the same motion. They differ in how an orientation error propagates: with
Baraff's world-axes ``L``, ``omega = R I_body^-1 R^T L`` depends on ``q``, so every error in
``q`` feeds back into ``omega`` and grows. With the body-axes ``L_b = R^T L``,
``omega_b = I_body^-1 L_b`` does not depend on ``q`` at all (Euler's equations). Measured
near the intermediate axis, RK4 is ~1000x more accurate at the same step in body axes
(docs/accuracy.md). The public state stays Baraff's; only the inside of a step changes.
"""
import numpy as np

from rigid_sim.core import rotation
from rigid_sim.core.integrators.base import omega_quaternion
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, ORIENTATION, POSITION


class WorldMomentum:
    """Baraff's state: ``d/dt [x, q, P, L] = [P/M, (omega, 0) q / 2, F, tau]``."""

    @staticmethod
    def to_internal(bodies, y):
        return y.copy()

    @staticmethod
    def to_public(bodies, z):
        return z

    @staticmethod
    def derivative(integrator, z, time):
        matrices = rotation.to_matrix(z[:, ORIENTATION])
        force, torque = integrator.wrench(z, time, matrices)
        bodies = integrator.bodies
        body_l = rotation.rotate_inverse(matrices, z[:, ANGULAR_MOMENTUM])
        omega = rotation.rotate(matrices, rotation.rotate(bodies.inertia_body_inv, body_l))
        dz = np.empty_like(z)
        dz[:, POSITION] = z[:, LINEAR_MOMENTUM] / bodies.mass[:, None]
        dz[:, ORIENTATION] = 0.5 * rotation.multiply(omega_quaternion(omega), z[:, ORIENTATION])
        dz[:, LINEAR_MOMENTUM] = force
        dz[:, ANGULAR_MOMENTUM] = torque
        return dz


class BodyMomentum:
    """Body-axes momentum: ``d/dt L_b = R^T tau - omega_b x L_b``, ``dq/dt = q (omega_b, 0)/2``."""

    @staticmethod
    def to_internal(bodies, y):
        z = y.copy()
        matrices = rotation.to_matrix(y[:, ORIENTATION])
        z[:, ANGULAR_MOMENTUM] = rotation.rotate_inverse(matrices, y[:, ANGULAR_MOMENTUM])
        return z

    @staticmethod
    def to_public(bodies, z):
        y = z.copy()
        matrices = rotation.to_matrix(rotation.normalize(z[:, ORIENTATION]))
        y[:, ANGULAR_MOMENTUM] = rotation.rotate(matrices, z[:, ANGULAR_MOMENTUM])
        return y

    @staticmethod
    def derivative(integrator, z, time):
        bodies = integrator.bodies
        matrices = rotation.to_matrix(z[:, ORIENTATION])
        body_l = z[:, ANGULAR_MOMENTUM]
        world = z.copy()
        world[:, ANGULAR_MOMENTUM] = rotation.rotate(matrices, body_l)
        force, torque = integrator.wrench(world, time, matrices)
        omega_body = rotation.rotate(bodies.inertia_body_inv, body_l)
        dz = np.empty_like(z)
        dz[:, POSITION] = z[:, LINEAR_MOMENTUM] / bodies.mass[:, None]
        dz[:, ORIENTATION] = 0.5 * rotation.multiply(z[:, ORIENTATION],
                                                     omega_quaternion(omega_body))
        dz[:, LINEAR_MOMENTUM] = force
        dz[:, ANGULAR_MOMENTUM] = (rotation.rotate_inverse(matrices, torque)
                                   - np.cross(omega_body, body_l))
        return dz
