# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The contract every integrator fulfils.

An integrator advances the packed Baraff state ``y`` (N, 13) = [x, q, P, L] of all bodies
by ``dt``. It is built for a *system*, which provides

``bodies``
    the :class:`~rigid_sim.core.state.RigidBodies`;
``effects``
    the effects the scene lists, each with ``accumulate(snapshot, force, torque)``
    (see :mod:`rigid_sim.core.effects`);
``torqued``
    (N,) bool, the bodies any effect of the scene may torque;
``velocity_dependent``
    bool, whether any effect's wrench depends on the momenta.

To write a new method, subclass :class:`Integrator`, set ``name``, ``order`` and
``adaptive``, implement ``_step_impl`` and add the class to the registry in
``integrators/__init__.py``. ``step`` keeps quaternions unit; ``wrench_rows`` (the
right-hand side's forces) counts evaluations. The state given to ``step`` is never modified.

Inside, states are component-major: ``rows`` (13, N) is ``y`` transposed, so each component
of every body is one contiguous row and one numpy call advances all bodies. ``_step_impl``
gets ``y.T`` (a view it must not write) and returns new C-contiguous rows; ``step`` returns
their transpose, an (N, 13) view, so callers index ``y[:, 0:3]`` as before. At large N a
fresh temporary costs page faults, so the hot paths write into buffers kept between steps.
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
        # Net force and torque rows, refilled by every wrench evaluation.
        self._wrench = np.empty((6, self.bodies.count))

    def step(self, y, time, dt):
        """State (N, 13) ``dt`` seconds after ``y`` (N, 13) at ``time``; ``y`` stays as it is."""
        rows = self._step_impl(np.asarray(y).T, time, dt)
        rotation.normalize_rows(rows[ORIENTATION], out=rows[ORIENTATION])
        return rows.T

    def wrench_rows(self, rows, time, rotation_rows=None, completion=None):
        """Net world force and torque about the centre of mass at state ``rows``.

        Parameters
        ----------
        rows : (13, N) float
            Component-major state [x, q, P, L].
        time : float
            s.
        rotation_rows : (3, 3, N) float, optional
            ``R`` of every body, if the caller has it.
        completion : callable, optional
            Finishes ``rows`` when an effect reads them
            (see :class:`~rigid_sim.core.state.Snapshot`).

        Returns
        -------
        force, torque : (3, N) float each
            N and N m, world axes; rows of one buffer that the next evaluation overwrites
            (copy them to keep them).
        """
        self.evaluations += 1
        wrench = self._wrench
        wrench.fill(0.0)
        force, torque = wrench[:3], wrench[3:]
        snapshot = Snapshot(self.bodies, rows.T, time, rotation_rows=rotation_rows,
                            completion=completion)
        for effect in self.system.effects:
            effect.accumulate(snapshot, force.T, torque.T)
        return force, torque

    def _step_impl(self, rows, time, dt):
        """Return new C-contiguous rows (13, N) ``dt`` after ``rows`` (13, N), left untouched."""
        raise NotImplementedError
