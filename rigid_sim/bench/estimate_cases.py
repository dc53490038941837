# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Cases that judge the error estimates, each with its own forces for the oracle.

Each case is one body (its centre of mass at its frame's origin) built twice: as a core
World from the core's effects and inputs, and as the wrench :mod:`rigid_sim.bench.oracles`
writes from the physics, so the oracle's motion shares no force code with the core. None
is a case of the stability or accuracy sets; ``rigid_sim_bench estimates`` runs them too
(``est_<key>``), the tests (test/test_error_estimates.py) against the oracle's own forces.
"""
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.bench import oracles
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import Springs, SpringSpec
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World

TURN = Rotation.from_rotvec([0.4, -0.3, 0.6])   # no body axis along a world axis
GRAVITY = np.array([0.0, 0.0, -9.81])           # m/s^2


@dataclass(frozen=True)
class EstimateCase:
    """One body, its start, its step, and its forces in core and oracle terms."""

    key: str
    mass: float              # kg
    moments: tuple           # principal moments, body axes, kg m^2
    x0: tuple                # m, world
    v0: tuple                # m/s, world
    q0: tuple                # (x, y, z, w), body to world
    omega0: tuple            # rad/s, body axes
    dt: float                # s
    title: str = ''
    springs: tuple = ()      # (stiffness, damping, body point, anchor)
    field: tuple = None      # uniform acceleration, m/s^2
    world_force: tuple = None   # (force, body point): held in world axes
    torque: tuple = None     # held in body axes, N m

    @property
    def inertia(self):
        """Return the body-axes inertia matrix: shape (3, 3), kg m^2."""
        return np.diag(self.moments)

    def world(self, integrator, error_control=False, tolerance=1e-6):
        """Return the case as a core World: bare steps unless ``error_control``."""
        bodies = RigidBodies((self.key,), np.array([self.mass]), self.inertia[None],
                             np.zeros((1, 3)))
        omega_world = Rotation.from_quat(self.q0).apply(self.omega0)
        y = initial_state(bodies, np.array([self.x0]), np.array([self.q0]),
                          np.array([self.v0]), omega_world[None])
        effects = []
        if self.springs:
            effects.append(Springs(bodies, [
                SpringSpec(body=0, point=np.array(point, float), stiffness=k, damping=c,
                           anchor=np.array(anchor, float))
                for k, c, point, anchor in self.springs]))
        if self.field is not None:
            effects.append(Gravity(bodies, self.field))
        inputs = None
        if self.world_force is not None or self.torque is not None:
            inputs = AppliedWrenches(bodies, 1e6, 1e6)
            if self.world_force is not None:
                inputs.hold(0, 'force', 'world_point', self.world_force[0],
                            point=self.world_force[1])
            if self.torque is not None:
                inputs.hold(0, 'torque', 'body', np.zeros(3), self.torque)
        return World(bodies, y, effects, integrator, tolerance, auto_substep=error_control,
                     inputs=inputs, error_control=error_control)

    def wrench(self):
        """Return the oracle's wrench, from :mod:`rigid_sim.bench.oracles` alone."""
        parts = [oracles.spring_at(k, point, anchor, c) for k, c, point, anchor in self.springs]
        if self.field is not None:
            parts.append(oracles.uniform_field(self.mass, self.field))
        if self.world_force is not None:
            parts.append(oracles.world_force_at(*self.world_force))
        if self.torque is not None:
            parts.append(oracles.body_torque(self.torque))
        return oracles.summed(*parts) if parts else oracles.no_wrench

    def exact_step(self, y, dt, start=0.0):
        """Return the packed state (13,) ``dt`` after the packed ``y`` (13,), by the oracle."""
        return oracles.packed_step(self.mass, self.inertia, y, dt, self.wrench(), start)

    def true_error(self, start_state, y, dt, start=0.0):
        """Return the scaled local error of ``y`` (13,), a step of ``dt`` from ``start_state``."""
        return oracles.scaled_error(self.mass, self.inertia,
                                    self.exact_step(start_state, dt, start), y, dt)


TILTED = tuple(TURN.as_quat())
CASES = {case.key: case for case in (
    # A thin rod spun about its middle axis, a little off it: the axis it leaves is unstable.
    EstimateCase('rod', 1.0, (1e-4, 1.0, 1.0001), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
                 (0.0, 0.0, 0.0, 1.0), (0.0, 100.0, 0.1), 1e-3,
                 'thin rod I = (1e-4, 1, 1.0001), omega (0, 100, 0.1), dt 1e-3'),
    # Two moments a millionth apart: the elliptic flow's parameter is nearly degenerate.
    EstimateCase('near_symmetric', 1.0, (0.5, 0.5000005, 0.2), (0.0, 0.0, 0.0),
                 (0.0, 0.0, 0.0), TILTED, (1.0, -2.0, 6.0), 1e-2,
                 'near-symmetric top I = (0.5, 0.5000005, 0.2), dt 1e-2'),
    # A spinning top whose tip a stiff spring holds at the origin, under gravity.
    EstimateCase('heavy_top', 2.0, (0.05, 0.05, 0.02), (0.1, 0.0, 0.3), (0.0, 0.0, 0.0),
                 tuple(Rotation.from_rotvec([0.3, 0.0, 0.0]).as_quat()), (0.5, 0.0, 40.0),
                 2e-3, 'heavy top on a pivot spring, gravity, dt 2e-3',
                 springs=((2e4, 0.0, (0.0, 0.0, -0.3), (0.0, 0.0, 0.0)),),
                 field=tuple(GRAVITY)),
    # A force held in world axes at a body point, a damped spring to an off-centre anchor.
    EstimateCase('pushed_damped', 1.5, (0.4, 0.7, 0.9), (0.5, 0.2, -0.1), (0.3, -0.2, 0.1),
                 TILTED, (1.0, -3.0, 2.0), 1e-2, 'world force at a point, damped spring, dt 1e-2',
                 springs=((60.0, 1.5, (0.2, 0.1, -0.1), (0.0, 0.3, 0.0)),),
                 world_force=((0.0, 4.0, -10.0), (0.15, -0.1, 0.05))),
    # A torque held in body axes, spinning the body up about a tilted axis.
    EstimateCase('body_torque', 1.0, (1.0, 2.0, 3.0), (0.0, 0.0, 0.0), (0.2, 0.0, 0.0),
                 TILTED, (0.3, 4.0, 0.2), 1e-2, 'torque held in body axes, dt 1e-2',
                 torque=(0.5, -1.0, 2.0)),
)}
