# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Stepping many bodies in one array is the same physics as stepping each body alone.

Bodies that share no effect are independent systems, so a vectorised step over all of them
must give each body the state it would have alone; two bodies joined by a spring are one
system and must match that pair stepped alone.
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import Springs, SpringSpec
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World

COUNT = 5
PAIR = (0, 1)                # joined by a spring; the other bodies are on their own
DT, STEPS = 0.01, 10
AGREEMENT = 1e-12            # relative: round-off of a few dozen operations per step
# An adaptive method picks one step size for all the bodies it carries, so a body shares its
# neighbours' steps: its state then agrees only to the error target.
ADAPTIVE_TOLERANCE = 1e-12
ADAPTIVE_AGREEMENT = 1e-8
GENERATOR = np.random.default_rng(6)
MASS = GENERATOR.uniform(0.5, 3.0, COUNT)
TILT = Rotation.random(COUNT, random_state=6).as_matrix()
# Principal moments of boxes with random sides, so each triple is physical.
SIDES = GENERATOR.uniform(0.2, 0.8, (COUNT, 3))
MOMENTS = MASS[:, None] / 12.0 * (np.sum(SIDES ** 2, axis=1, keepdims=True) - SIDES ** 2)
# Inertia not diagonal in the body frame, and the centre of mass off the frame origin.
INERTIA = TILT @ (MOMENTS[:, :, None] * np.eye(3)) @ TILT.transpose(0, 2, 1)
COM = GENERATOR.normal(scale=0.1, size=(COUNT, 3))
ORIGIN = GENERATOR.normal(size=(COUNT, 3))
ORIENTATION = Rotation.random(COUNT, random_state=7).as_quat()
VELOCITY = GENERATOR.normal(size=(COUNT, 3))
SPIN = GENERATOR.normal(scale=3.0, size=(COUNT, 3))
FRAMES = ('world', 'body', 'point', 'world_point', 'body')


def build(members, integrator):
    """Return a World of the bodies ``members`` (scene indices), every effect acting on them."""
    members = list(members)
    bodies = RigidBodies(tuple(f'b{i}' for i in members), MASS[members], INERTIA[members],
                         COM[members])
    wrenches = AppliedWrenches(bodies)
    for local, body in enumerate(members):
        wrenches.hold(local, 'test', FRAMES[body], (0.3 * body, 1.0, -0.5), (0.05, 0.0, 0.1),
                      point=(0.1, -0.2, 0.05))
    specs = [SpringSpec(local, np.array([0.05, 0.0, 0.1]), 20.0 + body, 0.3, 0.1 * body,
                        anchor=ORIGIN[body] + 0.5) for local, body in enumerate(members)]
    if set(PAIR) <= set(members):
        specs.append(SpringSpec(members.index(PAIR[0]), np.array([0.0, 0.1, 0.0]), 15.0, 0.2,
                                0.3, other=members.index(PAIR[1]),
                                other_point=np.array([0.1, 0.0, 0.0])))
    effects = [Gravity(bodies, (0.0, 0.0, -9.81)), Damping(bodies, 0.05, 0.02),
               Springs(bodies, specs)]
    y = initial_state(bodies, ORIGIN[members], ORIENTATION[members], VELOCITY[members],
                      SPIN[members])
    return World(bodies, y, effects, integrator, tolerance=ADAPTIVE_TOLERANCE,
                 auto_substep=False, inputs=wrenches, error_control=False)


def advance(world):
    for _ in range(STEPS):
        world.step(DT)
    return world.y


@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_vectorised_step_equals_each_system_alone(name):
    """Each independent body (and the spring-joined pair) ends where it would alone, to round-off.

    The joined pair really interacts (its motion differs without the spring).
    """
    together = advance(build(range(COUNT), name))
    systems = [PAIR] + [(i,) for i in range(COUNT) if i not in PAIR]
    agreement = ADAPTIVE_AGREEMENT if REGISTRY[name].adaptive else AGREEMENT
    for members in systems:
        alone = advance(build(members, name))
        scale = np.abs(alone).max(axis=0) + 1.0
        difference = np.abs(together[list(members)] - alone) / scale
        assert difference.max() <= agreement, (name, members, difference.max())
    unjoined = advance(build(PAIR[:1], name))
    assert np.abs(unjoined[0] - together[PAIR[0]]).max() > 1e-6
