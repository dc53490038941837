# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The short cuts of the step give the physics of the general path.

Bodies that share no effect are independent, so the exact free flow of a body must not depend
on which other bodies share its call (all elliptic: the unmasked path; mixed with a still and a
spherical body: the masked path). The step guard reuses the spin bound of the state it checked
at the end of the last step; a wrench held since then must still be seen.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.integrators.free_rotation import torque_free_flow
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World

AGREEMENT = 1e-13      # relative: round-off of one flow call, whatever the path
GENERATOR = np.random.default_rng(11)
COUNT = 6
MOMENTS = np.sort(GENERATOR.uniform(0.5, 3.0, (COUNT, 3)), axis=1)[:, ::-1].copy()
ANGULAR_MOMENTUM = GENERATOR.normal(scale=2.0, size=(COUNT, 3))
ORIENTATION = Rotation.random(COUNT, random_state=11).as_quat()
DT = 0.37   # s: several radians turned, so any difference in the paths would show


def test_free_flow_of_a_body_does_not_depend_on_its_companions():
    """Each asymmetric body flows to the same state, whatever its companions.

    Alone (unmasked path), with all the others (unmasked) and beside a still and a spherical
    body (masked path), the states agree to round-off; the still body stays still and the
    sphere keeps its angular momentum.
    """
    together = torque_free_flow(MOMENTS, ANGULAR_MOMENTUM, ORIENTATION, DT)
    mixed_moments = np.vstack((MOMENTS, [[1.0, 1.0, 1.0], [1.0, 2.0, 3.0]]))
    mixed_l = np.vstack((ANGULAR_MOMENTUM, [[0.3, -0.2, 0.5], [0.0, 0.0, 0.0]]))
    mixed_q = np.vstack((ORIENTATION, ORIENTATION[:2]))
    mixed = torque_free_flow(mixed_moments, mixed_l, mixed_q, DT)
    for body in range(COUNT):
        alone = torque_free_flow(MOMENTS[body:body + 1], ANGULAR_MOMENTUM[body:body + 1],
                                 ORIENTATION[body:body + 1], DT)
        for result in (together, mixed):
            for got, expected in zip(result, alone):
                scale = np.abs(expected[0]).max()
                assert np.abs(got[body] - expected[0]).max() <= AGREEMENT * scale
    np.testing.assert_array_equal(mixed[0][-1], 0.0)
    np.testing.assert_allclose(mixed[1][-1], ORIENTATION[1], rtol=AGREEMENT)
    np.testing.assert_allclose(mixed[0][-2], mixed_l[-2], rtol=AGREEMENT)


def test_guard_sees_a_wrench_held_between_steps():
    """A torque-free body moves exactly at any step, so a fast spin takes one substep.

    Once a torque is held on it, |omega| dt above the exact_split bound splits the step.
    """
    bodies = RigidBodies(('spinner',), np.ones(1), np.diag([1.0, 2.0, 3.0])[None],
                         np.zeros((1, 3)))
    y = initial_state(bodies, np.zeros((1, 3)), [[0.0, 0.0, 0.0, 1.0]], np.zeros((1, 3)),
                      [[0.0, 0.0, 20.0]])   # |omega| dt = 0.2, four times the bound
    wrenches = AppliedWrenches(bodies)
    world = World(bodies, y, [], 'exact_split', inputs=wrenches)
    dt = 0.01
    world.step(dt)
    assert world.diagnostics.substeps == 1
    wrenches.hold(0, 'push', 'body', (0.0, 0.0, 0.0), (0.0, 0.0, 0.1))
    world.step(dt)
    assert world.diagnostics.substeps > 1
    wrenches.release()
    world.step(dt)
    assert world.diagnostics.substeps == 1
