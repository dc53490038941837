"""The world: bodies, their state, the effects the scene lists, and one integrator."""
import numpy as np

from rigid_sim.core.integrators import make_integrator
from rigid_sim.core.state import Snapshot


class World:
    """Advances all bodies together.

    Parameters
    ----------
    bodies : RigidBodies
    initial : (N, 13) float, packed Baraff state at time 0
    effects : list of effects (see :mod:`rigid_sim.core.effects`); only what the scene lists
    integrator : str, a registered integrator name
    tolerance : float, error target of adaptive integrators
    """

    def __init__(self, bodies, initial, effects=(), integrator='rk4', tolerance=1e-6):
        self.bodies = bodies
        self.initial = np.array(initial, dtype=float)
        self.effects = list(effects)
        self.torqued = np.zeros(bodies.count, dtype=bool)
        for effect in self.effects:
            self.torqued |= effect.torqued
        self.velocity_dependent = any(e.velocity_dependent for e in self.effects)
        self._expiring = [e for e in self.effects if hasattr(e, 'expire')]
        self.integrator = make_integrator(integrator, self, tolerance)
        self.reset()

    def effect(self, kind):
        """The effect of class ``kind`` in this world, or None when the scene has none."""
        return next((e for e in self.effects if isinstance(e, kind)), None)

    def reset(self):
        """Back to the initial state at time 0."""
        self.y = self.initial.copy()
        self.time = 0.0

    def wrench(self, snapshot):
        """Net world force and torque about the centre of mass, (N, 3) each."""
        force = np.zeros((self.bodies.count, 3))
        torque = np.zeros((self.bodies.count, 3))
        for effect in self.effects:
            effect.accumulate(snapshot, force, torque)
        return force, torque

    def step(self, dt):
        """Advance every body by ``dt`` seconds of simulated time."""
        for effect in self._expiring:
            effect.expire(self.time)
        self.y = self.integrator.step(self.y, self.time, dt)
        self.time += dt

    def snapshot(self):
        """Kinematics of the current state."""
        return Snapshot(self.bodies, self.y, self.time)

    def energy(self):
        """Total mechanical energy, J: kinetic plus every effect's potential."""
        snapshot = self.snapshot()
        potential = sum(effect.potential_energy(snapshot) for effect in self.effects)
        return float(np.sum(snapshot.kinetic_energy()) + potential)
