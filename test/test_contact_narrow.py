# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The narrow phase against python-fcl (FCL's GJK/EPA), an implementation that shares nothing.

For each overlapping pair of primitives in random poses, the deepest contact the stage
finds must be as deep as FCL's signed distance says, and moving the second body along the
contact's normal by that depth must separate the pair; pairs that do not overlap give no
contact.
"""
import fcl
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigid_sim.core.contact import Contact
from rigid_sim.core.contact.narrow import FACE_PREFERENCE
from rigid_sim.core.inertia import shape_mass_properties
from rigid_sim.core.state import RigidBodies, initial_state

CASES = 40


def fcl_shape(shape):
    if shape['type'] == 'sphere':
        return fcl.Sphere(shape['radius'])
    return fcl.Box(*shape['size'])


def random_shape(rng, kind):
    if kind == 'sphere':
        return {'type': 'sphere', 'radius': rng.uniform(0.05, 0.3)}
    return {'type': 'box', 'size': list(rng.uniform(0.1, 0.6, 3))}


def found_contacts(shapes, positions, turns):
    """Run the contact stage once on bodies at rest; return (distances, normals) found."""
    properties = [shape_mass_properties(shape, {'method': 'exact'}, mass=1.0)
                  for shape in shapes]
    bodies = RigidBodies(('a', 'b'), np.ones(2), np.array([p.inertia for p in properties]),
                         np.zeros((2, 3)))
    y = initial_state(bodies, np.array(positions), np.array([t.as_quat() for t in turns]),
                      np.zeros((2, 3)), np.zeros((2, 3)))
    contact = Contact(bodies, shapes, np.zeros((0, 4)))
    count = contact.resolve(y, 1e-3, bodies.model)
    order = contact.work.order[:count]
    return contact.work.contacts.distance[order], contact.work.contacts.normal[order]


@pytest.mark.parametrize('kinds', [('sphere', 'sphere'), ('sphere', 'box'), ('box', 'sphere'),
                                   ('box', 'box')])
def test_deepest_contact_matches_fcl_signed_distance(kinds):
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(CASES):
        shapes = [random_shape(rng, kind) for kind in kinds]
        turns = [Rotation.random(random_state=rng) for _ in kinds]
        positions = [np.zeros(3), rng.uniform(-0.4, 0.4, 3)]
        objects = [fcl.CollisionObject(fcl_shape(s), fcl.Transform(t.as_matrix(), p))
                   for s, t, p in zip(shapes, turns, positions)]
        result = fcl.DistanceResult()
        signed = fcl.distance(*objects, fcl.DistanceRequest(enable_signed_distance=True),
                              result)
        distances, normals = found_contacts(shapes, positions, turns)
        if signed > 1e-4:
            assert len(distances) == 0
            continue
        if signed > -1e-4:
            continue   # grazing: FCL's own tolerance decides
        checked += 1
        deepest = int(np.argmin(distances))
        if 'sphere' in kinds:
            assert distances[deepest] == pytest.approx(signed, abs=1e-6)
        else:
            # Box-box may take a face axis up to FACE_PREFERENCE worse than the best edge
            # axis (a patch rather than one point): never shallower than FCL's depth.
            assert signed / FACE_PREFERENCE - 1e-6 <= distances[deepest] <= signed + 1e-6
        # The normal points from b to a: b moves the other way out by the depth.
        separated = [fcl.CollisionObject(
            fcl_shape(shapes[1]),
            fcl.Transform(turns[1].as_matrix(),
                          positions[1] - normals[deepest] * (-signed + 1e-3)))]
        apart = fcl.distance(objects[0], separated[0], fcl.DistanceRequest(),
                             fcl.DistanceResult())
        assert apart > 0.0
    assert checked >= CASES // 4
