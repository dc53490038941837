"""Semi-implicit (symplectic) Euler: kick the momenta, then drift with the new velocities."""
from rigid_sim.core import rotation
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, ORIENTATION, POSITION


class SemiImplicitEuler(Integrator):
    """``P += F dt, L += tau dt``; then ``x += v dt`` and ``q <- exp(omega dt) q``. Order 1.

    The rotation is applied as an exact exponential, so ``q`` stays unit without help and
    a spring's energy stays bounded for ``omega dt < 2`` instead of growing as in ``euler``.
    ``omega`` uses the new ``L`` with the old orientation.
    """

    name = 'semi_implicit_euler'
    order = 1

    def _step_impl(self, y, time, dt):
        matrices = rotation.to_matrix(y[:, ORIENTATION])
        force, torque = self.wrench(y, time, matrices)
        y_next = y.copy()
        y_next[:, LINEAR_MOMENTUM] += dt * force
        y_next[:, ANGULAR_MOMENTUM] += dt * torque
        body_l = rotation.rotate_inverse(matrices, y_next[:, ANGULAR_MOMENTUM])
        omega = rotation.rotate(matrices, rotation.rotate(self.bodies.inertia_body_inv, body_l))
        y_next[:, POSITION] += dt * y_next[:, LINEAR_MOMENTUM] / self.bodies.mass[:, None]
        turn = rotation.exp_map(dt * omega)
        y_next[:, ORIENTATION] = rotation.multiply(turn, y[:, ORIENTATION])
        return y_next
