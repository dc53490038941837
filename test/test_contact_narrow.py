# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The narrow phase against python-fcl (FCL's GJK/EPA), an implementation that shares nothing.

For each overlapping pair of primitives in random poses, the deepest contact the stage
finds must be as deep as FCL's signed distance says, and moving the second body along the
contact's normal by that depth must separate the pair; pairs that do not overlap give no
contact. Against planes (FCL's half spaces crash python-fcl's distance), the lowest point
of each shape is its support along the plane's normal, written out here.
"""
import math

import fcl
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigid_sim.core.contact import Contact
from rigid_sim.core.contact.narrow import FACE_PREFERENCE
from rigid_sim.core.inertia import shape_mass_properties
from rigid_sim.core.state import RigidBodies, initial_state

pytestmark = pytest.mark.usefixtures('every_shape_kind')   # one stage compile (conftest)

CASES = 40


def fcl_shape(shape):
    if shape['type'] == 'sphere':
        return fcl.Sphere(shape['radius'])
    if shape['type'] == 'capsule':   # FCL's length is the segment's, as ours
        return fcl.Capsule(shape['radius'], shape['length'])
    if shape['type'] == 'cylinder':
        return fcl.Cylinder(shape['radius'], shape['length'])
    return fcl.Box(*shape['size'])


def random_shape(rng, kind):
    if kind == 'sphere':
        return {'type': 'sphere', 'radius': rng.uniform(0.05, 0.3)}
    if kind in ('capsule', 'cylinder'):
        return {'type': kind, 'radius': rng.uniform(0.05, 0.3), 'length': rng.uniform(0.1, 0.6)}
    return {'type': 'box', 'size': list(rng.uniform(0.1, 0.6, 3))}


def found_contacts(shapes, positions, turns, planes=np.zeros((0, 4))):
    """Run the contact stage once on bodies at rest; return (distances, normals) found."""
    # A capsule body's inertia as a cylinder's: detection does not read it.
    properties = [shape_mass_properties(dict(shape, type='cylinder')
                                        if shape['type'] == 'capsule' else shape,
                                        {'method': 'exact'}, mass=1.0) for shape in shapes]
    n = len(shapes)
    bodies = RigidBodies(tuple('ab'[:n]), np.ones(n), np.array([p.inertia for p in properties]),
                         np.zeros((n, 3)))
    y = initial_state(bodies, np.array(positions), np.array([t.as_quat() for t in turns]),
                      np.zeros((n, 3)), np.zeros((n, 3)))
    contact = Contact(bodies, shapes, planes)
    count = contact.resolve(y, 1e-3, bodies.model)
    order = contact.work.order[:count]
    return contact.work.contacts.distance[order], contact.work.contacts.normal[order]


PAIRS = [('sphere', 'sphere'), ('sphere', 'box'), ('box', 'sphere'), ('box', 'box'),
         ('capsule', 'sphere'), ('sphere', 'capsule'), ('capsule', 'capsule'),
         ('capsule', 'box'), ('box', 'capsule'), ('cylinder', 'sphere'),
         ('sphere', 'cylinder'), ('cylinder', 'box'), ('box', 'cylinder'),
         ('cylinder', 'capsule'), ('capsule', 'cylinder'), ('cylinder', 'cylinder')]


@pytest.mark.parametrize('kinds', PAIRS)
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
        if kinds != ('box', 'box'):
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


def lowest_point_height(shape, turn, position, normal):
    """Height over the plane ``normal . x = 0`` of the shape's lowest point (its support).

    Along the shape's axis ``a``: a capsule reaches ``l/2 |n.a| + r`` below its centre, a
    cylinder ``l/2 |n.a| + r sin(angle(n, a))`` (its rim), a box ``sum h_k |n.e_k|``.
    """
    axes = turn.as_matrix()
    if shape['type'] == 'box':
        reach = sum(0.5 * edge * abs(normal @ axes[:, k]) for k, edge in enumerate(shape['size']))
    else:
        along = abs(normal @ axes[:, 2])
        across = 1.0 if shape['type'] == 'capsule' else math.sqrt(max(0.0, 1.0 - along ** 2))
        reach = 0.5 * shape['length'] * along + shape['radius'] * across
    return normal @ position - reach


@pytest.mark.parametrize('kind', ['box', 'capsule', 'cylinder'])
def test_deepest_plane_contact_is_the_lowest_point(kind):
    rng = np.random.default_rng(11)
    for _ in range(CASES):
        shape = random_shape(rng, kind)
        turn = Rotation.random(random_state=rng)
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        position = rng.uniform(-0.3, 0.3, 3)
        height = lowest_point_height(shape, turn, position, normal)
        distances, normals = found_contacts([shape], [position], [turn],
                                            np.array([[*normal, 0.0]]))
        if height > 1e-4:
            assert len(distances) == 0
            continue
        assert distances.min() == pytest.approx(height, abs=1e-12)
        np.testing.assert_allclose(normals, np.tile(normal, (len(normals), 1)), atol=1e-15)
