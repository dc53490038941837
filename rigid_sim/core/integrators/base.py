"""The contract every integrator fulfils.

An integrator advances the packed Baraff state ``y`` (N, 13) = [x, q, P, L] of all bodies
by ``dt``. It is built for a *system*, which provides

``bodies``
    the :class:`~rigid_sim.core.state.RigidBodies`;
``wrench(snapshot)``
    net world force and torque about the centre of mass, (N, 3) each, at a
    :class:`~rigid_sim.core.state.Snapshot`;
``torqued``
    (N,) bool, the bodies any effect of the scene may torque;
``velocity_dependent``
    bool, whether any effect's wrench depends on the momenta.

To write a new method, subclass :class:`Integrator`, set ``name``, ``order`` and
``adaptive``, implement ``_step_impl`` and add the class to the registry in
``integrators/__init__.py``. ``step`` owns the bookkeeping: it keeps quaternions unit and
counts right-hand-side evaluations. The state given to ``step`` is never modified.
"""
import numpy as np

from rigid_sim.core import rotation
from rigid_sim.core.state import ORIENTATION, Snapshot


class Integrator:
    """Base class: one step of ``dt`` for every body at once."""

    name = ''
    order = 0          # global order of accuracy
    adaptive = False   # True: ``tolerance`` controls the error, not ``dt``

    def __init__(self, system, tolerance=1e-6):
        self.system = system
        self.bodies = system.bodies
        self.tolerance = float(tolerance)
        self.evaluations = 0     # wrench evaluations since construction
        self.last_substeps = 1   # internal steps the last call took (adaptive methods)

    def step(self, y, time, dt):
        """State after ``dt`` seconds from ``y`` at ``time``; ``y`` is left untouched."""
        y_next = self._step_impl(y, time, dt)
        y_next[:, ORIENTATION] = rotation.normalize(y_next[:, ORIENTATION])
        return y_next

    def wrench(self, y, time, matrices=None):
        """Net force and torque (N, 3) on every body at state ``y``."""
        self.evaluations += 1
        return self.system.wrench(Snapshot(self.bodies, y, time, matrices))

    def _step_impl(self, y, time, dt):
        raise NotImplementedError


def omega_quaternion(omega):
    """Pure quaternions ``(omega, 0)``, (N, 3) -> (N, 4)."""
    return np.concatenate((omega, np.zeros((omega.shape[0], 1))), axis=1)
