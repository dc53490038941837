# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Mass properties of shapes and meshes against closed forms derived here."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
import trimesh

from rigid_sim.core import inertia as mp

SIZE = np.array([0.3, 0.2, 0.1])
MASS = 2.0


def box_inertia(size, mass):
    a, b, c = size
    return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def rel_error(estimate, exact):
    return np.linalg.norm(estimate - exact) / np.linalg.norm(exact)


def l_block_mesh(height):
    """L profile (legs 0.1 m wide, 0.3 x 0.2 m overall) extruded along z, corner at origin."""
    profile = np.array([[0, 0], [0.3, 0], [0.3, 0.1], [0.1, 0.1], [0.1, 0.2], [0, 0.2]])
    n = len(profile)
    vertices = np.vstack([np.column_stack([profile, np.full(n, z)]) for z in (0.0, height)])
    # The L is star-shaped from its outer corner, so a fan from vertex 0 triangulates it.
    top = [[n, n + i, n + i + 1] for i in range(1, n - 1)]
    bottom = [[0, i + 1, i] for i in range(1, n - 1)]
    sides = [tri for i in range(n) for tri in
             ([i, (i + 1) % n, n + (i + 1) % n], [i, n + (i + 1) % n, n + i])]
    return trimesh.Trimesh(vertices, top + bottom + sides)


def l_block_exact(height, density):
    """Two boxes combined by the parallel-axis theorem: I = sum I_i + m_i (|d|^2 E - d d^T)."""
    legs = [(np.array([0.3, 0.1, height]), np.array([0.15, 0.05, height / 2])),
            (np.array([0.1, 0.1, height]), np.array([0.05, 0.15, height / 2]))]
    masses = [density * np.prod(size) for size, _ in legs]
    com = sum(m * c for m, (_, c) in zip(masses, legs)) / sum(masses)
    inertia = np.zeros((3, 3))
    for m, (size, centre) in zip(masses, legs):
        d = centre - com
        inertia += box_inertia(size, m) + m * (d @ d * np.eye(3) - np.outer(d, d))
    return sum(masses), com, inertia


def test_primitives_match_closed_forms():
    """Box m(b^2+c^2)/12..., sphere 2/5 m r^2, cylinder m(3r^2+l^2)/12 and m r^2/2 about z."""
    np.testing.assert_allclose(mp.box(SIZE, mass=MASS).inertia, box_inertia(SIZE, MASS))
    np.testing.assert_allclose(mp.sphere(0.5, mass=MASS).inertia, 0.4 * MASS * 0.25 * np.eye(3))
    np.testing.assert_allclose(mp.cylinder(0.5, 2.0, mass=MASS).inertia,
                               np.diag([MASS * 4.75 / 12, MASS * 4.75 / 12, MASS * 0.125]))
    assert mp.sphere(0.5, density=1000.0).mass == pytest.approx(1000.0 * math.pi / 6)


def test_box_mesh_is_exact():
    """A box mesh is the box: Mirtich's integrals are exact for polyhedra."""
    result = mp.mesh_exact(trimesh.creation.box(SIZE), density=500.0)
    assert result.mass == pytest.approx(500.0 * np.prod(SIZE), rel=1e-12)
    np.testing.assert_allclose(result.inertia, box_inertia(SIZE, result.mass), atol=1e-15)


def test_cylinder_and_sphere_meshes_approach_closed_forms():
    """Faceted meshes converge to the solid; a 256-gon loses ~(2 pi/256)^2/6 of its area."""
    cylinder = mp.mesh_exact(trimesh.creation.cylinder(0.5, 2.0, sections=256), mass=MASS)
    np.testing.assert_allclose(cylinder.inertia, mp.cylinder(0.5, 2.0, mass=MASS).inertia,
                               rtol=1e-3, atol=1e-12)
    # An icosphere's inscribed facets fall short of the radius by ~0.2% at 4 subdivisions.
    ball = mp.mesh_exact(trimesh.creation.icosphere(subdivisions=4, radius=0.5), mass=MASS)
    np.testing.assert_allclose(ball.inertia, mp.sphere(0.5, mass=MASS).inertia,
                               rtol=5e-3, atol=1e-12)


def test_rotated_translated_mesh_gives_r_i_rt():
    """Moving a body by (R, t) moves its centre of mass to t and its inertia to R I R^T."""
    rotation = Rotation.from_rotvec([0.3, -0.7, 1.1])
    transform = np.eye(4)
    transform[:3, :3], transform[:3, 3] = rotation.as_matrix(), [1.0, -2.0, 0.5]
    mesh = trimesh.creation.box(SIZE)
    mesh.apply_transform(transform)
    result = mp.mesh_exact(mesh, mass=MASS)
    np.testing.assert_allclose(result.center_of_mass, [1.0, -2.0, 0.5], atol=1e-12)
    r = rotation.as_matrix()
    np.testing.assert_allclose(result.inertia, r @ box_inertia(SIZE, MASS) @ r.T, atol=1e-14)


def test_far_mesh_keeps_precision():
    """Inertia about the centre of mass does not depend on where the mesh sits (recentred)."""
    offset = 1e4 * np.linalg.norm(SIZE) * np.array([1.0, 0.6, -0.3])
    mesh = trimesh.creation.box(SIZE)
    mesh.apply_translation(offset)
    result = mp.mesh_exact(mesh, mass=MASS)
    assert rel_error(result.inertia, box_inertia(SIZE, MASS)) < 1e-9
    np.testing.assert_allclose(result.center_of_mass, offset, rtol=1e-12)


def test_non_convex_l_block():
    """An L-block's inertia is its two legs' by the parallel-axis theorem."""
    mass, com, inertia = l_block_exact(0.1, density=700.0)
    result = mp.mesh_exact(l_block_mesh(0.1), density=700.0)
    assert result.mass == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(result.center_of_mass, com, atol=1e-12)
    np.testing.assert_allclose(result.inertia, inertia, atol=1e-12 * np.max(inertia))


def test_bounding_box_of_sphere_is_five_thirds():
    """Box of edge 2r: m/12 (4r^2 + 4r^2) = 2/3 m r^2, which is 5/3 of the sphere's 2/5 m r^2."""
    for solid in ({'type': 'sphere', 'radius': 0.5},
                  trimesh.creation.icosphere(subdivisions=3, radius=0.5)):
        result = mp.bounding_box_estimate(solid, mass=MASS)
        np.testing.assert_allclose(result.inertia, 2.0 / 3.0 * MASS * 0.25 * np.eye(3),
                                   rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(result.center_of_mass, 0.0, atol=1e-12)


def sphere_error(samples, sequence, seed):
    solid = {'type': 'sphere', 'radius': 0.5}
    estimate = mp.sampling_estimate(solid, samples, sequence, seed=seed, mass=MASS)
    return rel_error(estimate.inertia, mp.sphere(0.5, mass=MASS).inertia)


def test_sampling_errors_within_bounds():
    """Random sampling errs ~1/sqrt(N); Sobol on a solid's discontinuous inside test ~N^(-2/3)."""
    n = 2 ** 14
    for seed in range(4):
        assert sphere_error(n, 'sobol', seed) < 5.0 * n ** (-2.0 / 3.0)
        assert sphere_error(n, 'random', seed) < 5.0 / math.sqrt(n)


def test_sobol_beats_random_on_average():
    """Scrambled Sobol points fill space more evenly than random ones at the same N."""
    n, seeds = 2 ** 12, range(8)
    sobol = np.mean([sphere_error(n, 'sobol', seed) for seed in seeds])
    random = np.mean([sphere_error(n, 'random', seed) for seed in seeds])
    assert sobol < random / 2


def test_sampling_mesh_approaches_exact():
    """Points inside a non-convex mesh average to its centre of mass and inertia."""
    mass, com, inertia = l_block_exact(0.1, density=700.0)
    result = mp.sampling_estimate(l_block_mesh(0.1), 2 ** 12, density=700.0)
    assert result.mass == pytest.approx(mass)
    np.testing.assert_allclose(result.center_of_mass, com, atol=2e-3)
    assert rel_error(result.inertia, inertia) < 2e-2


def test_shape_mass_properties_reads_scene_dicts(tmp_path):
    """The scene entry point: files relative to base_dir, a given tensor at the shape's COM."""
    l_block_mesh(0.1).export(tmp_path / 'l.stl')
    mass, com, inertia = l_block_exact(0.2, density=700.0)
    shape = {'type': 'mesh', 'file': 'l.stl', 'scale': [1.0, 1.0, 2.0]}
    exact = mp.shape_mass_properties(shape, {'method': 'exact'}, density=700.0,
                                     base_dir=str(tmp_path))
    # STL stores float32 vertices: ~1e-7 relative.
    np.testing.assert_allclose(exact.inertia, inertia, rtol=1e-6, atol=1e-6 * np.max(inertia))
    given = mp.shape_mass_properties(shape, {'diagonal': [1.0, 1.0, 1.5]}, mass=3.0,
                                     base_dir=str(tmp_path))
    np.testing.assert_allclose(given.center_of_mass, com, atol=1e-7)
    np.testing.assert_allclose(given.inertia, np.diag([1.0, 1.0, 1.5]))
    ball = mp.shape_mass_properties({'type': 'sphere', 'radius': 0.5},
                                    {'method': 'bounding_box'}, density=1000.0)
    assert ball.mass == pytest.approx(1000.0 * math.pi / 6)


def open_box():
    box = trimesh.creation.box(SIZE)
    return trimesh.Trimesh(box.vertices, box.faces[1:], process=False)


def one_face_flipped():
    faces = trimesh.creation.box(SIZE).faces.copy()
    faces[0] = faces[0][::-1]
    return trimesh.Trimesh(trimesh.creation.box(SIZE).vertices, faces, process=False)


def inside_out():
    box = trimesh.creation.box(SIZE)
    return trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False)


@pytest.mark.parametrize('mesh, message', [
    (open_box(), 'not watertight'),
    (one_face_flipped(), 'winding is not consistent'),
    (inside_out(), 'not positive'),
])
def test_unclosed_meshes_are_refused(mesh, message):
    """Only a closed, consistently outward-wound surface bounds a solid with mass."""
    with pytest.raises(ValueError, match=message):
        mp.mesh_exact(mesh, mass=MASS)
    with pytest.raises(ValueError, match=message):
        mp.sampling_estimate(mesh, 64, mass=MASS)


@pytest.mark.parametrize('matrix, message', [
    ([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], 'not symmetric'),
    (np.diag([-0.01, 0.02, 0.02]), 'not positive definite'),
    (np.diag([0.01, 0.01, 0.05]), 'triangle inequality'),
])
def test_unphysical_inertia_is_refused(matrix, message):
    """A tensor is a body's only if symmetric, positive definite and I1 + I2 >= I3."""
    with pytest.raises(ValueError, match=message):
        mp.check_inertia(matrix)
    with pytest.raises(ValueError, match=message):
        mp.given(MASS, matrix=matrix)


def test_flat_plate_is_accepted():
    """A thin plate sits on the triangle inequality's edge: I1 + I2 = I3 is physical."""
    mp.check_inertia(box_inertia([1.0, 2.0, 1e-9], MASS))


def test_bad_amounts_and_files_are_refused(tmp_path):
    """Mass is positive, given once (mass or density), and a mesh file must exist."""
    with pytest.raises(ValueError, match='mass must be finite and > 0'):
        mp.box(SIZE, mass=0.0)
    with pytest.raises(ValueError, match='density must be finite and > 0'):
        mp.sphere(0.5, density=float('nan'))
    with pytest.raises(ValueError, match='exactly one of mass'):
        mp.box(SIZE, mass=1.0, density=1.0)
    with pytest.raises(ValueError, match='exactly one of mass'):
        mp.box(SIZE)
    with pytest.raises(FileNotFoundError, match='mesh file not found'):
        mp.shape_mass_properties({'type': 'mesh', 'file': 'none.stl'}, {'method': 'exact'},
                                 mass=1.0, base_dir=str(tmp_path))
