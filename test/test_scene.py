# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Scene files: every shipped scene builds, every mistake is refused with file, key and reason."""
import copy
import glob
import os
import re
import shutil

import numpy as np
import pytest
import trimesh
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import Springs
from rigid_sim.core.scene import (
    SceneError, build_world, check_world_frame, load_scene, parse_scene, wrench_target)

CONFIG = os.path.join(os.path.dirname(__file__), '..', 'config')
SHIPPED = sorted(glob.glob(os.path.join(CONFIG, 'scenes', '*.yaml')))
L_BLOCK = os.path.join(CONFIG, 'meshes', 'l_block.obj')
# Centre of mass of the unit L block: a 0.3 x 0.1 leg (centre 0.15, 0.05) and a 0.1 x 0.1
# leg (centre 0.05, 0.15), both 0.1 m thick, weighted by area 3 : 1.
L_BLOCK_COM = np.array([(3 * 0.15 + 0.05) / 4, (3 * 0.05 + 0.15) / 4, 0.05])

VALID = {
    'world_frame': 'world',
    'limits': {'max_force': 100.0, 'max_torque': 10.0},
    'effects': {
        'gravity': {'acceleration': [0.0, 0.0, -9.81]},
        'damping': {'linear': 0.1, 'angular': 0.1},
        'springs': [
            {'body': 'box', 'point': [0.2, 0.0, 0.0], 'anchor': [0.0, 0.0, 1.0],
             'stiffness': 50.0, 'damping': 0.5, 'rest_length': 0.1},
            {'body': 'box', 'other': 'ball', 'stiffness': 10.0}]},
    'bodies': [
        {'name': 'box', 'shape': {'type': 'box', 'size': [0.4, 0.2, 0.1]}, 'mass': 2.0,
         'pose': {'position': [0.0, 0.0, 1.0], 'orientation': [0.0, 0.0, 0.0, 1.0]},
         'points': {'thruster': [0.2, 0.0, 0.0]}},
        {'name': 'ball', 'shape': {'type': 'sphere', 'radius': 0.1}, 'density': 1000.0,
         'inertia': {'method': 'given', 'diagonal': [0.004, 0.004, 0.004]}}],
}


def scene_with(change):
    """Return a deep copy of the valid scene with ``change(data)`` applied."""
    data = copy.deepcopy(VALID)
    change(data)
    return data


def test_valid_scene_parses():
    """The reference scene is valid, so the mistakes below are the only thing wrong."""
    scene = parse_scene(copy.deepcopy(VALID))
    assert [body.name for body in scene.bodies] == ['box', 'ball']
    assert scene.bodies[0].mass_properties.mass == pytest.approx(2.0)
    # density x volume of a 0.1 m sphere
    assert scene.bodies[1].mass_properties.mass == pytest.approx(1000.0 * 4 / 3 * np.pi * 1e-3)
    assert scene.effects['springs'][1].other == 1


def test_given_inertia_in_either_spelling_is_the_tensor_given():
    """Both spellings of a given inertia give the body exactly the moments written.

    ``given: {matrix: ..}`` (README) and ``diagonal: ..`` give the principal moments written,
    about the centre of mass.
    """
    tensor = [[0.003, 0.001, 0.0], [0.001, 0.003, 0.0], [0.0, 0.0, 0.004]]   # moments 2, 4, 4
    nested = parse_scene(scene_with(put('bodies', 1, 'inertia', {'given': {'matrix': tensor}})))
    diagonal = {'diagonal': [0.002, 0.004, 0.004]}
    flat = parse_scene(scene_with(put('bodies', 1, 'inertia', diagonal)))
    for scene in (nested, flat):
        moments = np.linalg.eigvalsh(scene.bodies[1].mass_properties.inertia)
        assert moments == pytest.approx([0.002, 0.004, 0.004], rel=1e-12)


@pytest.mark.parametrize('path', SHIPPED, ids=os.path.basename)
def test_shipped_scene_loads_builds_and_steps(path):
    """Each shipped scene builds a world whose energy stays finite over a few steps."""
    world = build_world(load_scene(path))
    for _ in range(10):
        world.step(1e-3)
    assert np.all(np.isfinite(world.y))
    assert np.isfinite(world.energy())


def test_every_effect_has_an_example_scene():
    """The packaged examples cover every effect and the torque-free case."""
    names = {os.path.basename(path) for path in SHIPPED}
    assert {'default.yaml', 'gravity.yaml', 'damping.yaml', 'springs.yaml', 'wrenches.yaml',
            'mesh.yaml', 'torque_free.yaml'} <= names


def first_flip_of_free_plate(size, mass, omega_body, end):
    """Time at which body-y angular velocity first changes sign, from Euler's equations."""
    a, b, c = size
    moments = mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])

    def euler(_, omega):
        return np.cross(moments * omega, omega) / moments
    solution = solve_ivp(euler, (0.0, end), omega_body, rtol=1e-10, atol=1e-12,
                         events=lambda _, omega: omega[1])
    return solution.t_events[0][0]


def test_default_scene_handle_flips_as_a_free_body():
    """The default handle is torque-free (hung at its centre of mass).

    It flips about its intermediate axis when Euler's equations say, with |L| constant.
    """
    world = build_world(load_scene(os.path.join(CONFIG, 'scenes', 'default.yaml')))
    flip = first_flip_of_free_plate((0.20, 0.10, 0.04), 0.5, [0.01, 6.0, 0.0], 5.0)
    handle = world.bodies.index('handle')
    momentum = np.linalg.norm(world.y[handle, 10:13])
    dt, times, spin = 5e-3, [], []
    while world.time < flip + 0.5:
        snapshot = world.snapshot()
        times.append(world.time)
        turn = Rotation.from_quat(snapshot.y[handle, 3:7])
        spin.append(turn.inv().apply(snapshot.angular_velocity[handle])[1])
        world.step(dt)
    simulated_flip = times[int(np.argmax(np.array(spin) < 0.0))]
    assert simulated_flip == pytest.approx(flip, abs=2 * dt)
    assert np.linalg.norm(world.y[handle, 10:13]) == pytest.approx(momentum, rel=1e-9)


def effect_kinds(world):
    return sorted(type(effect).__name__ for effect in world.effects)


def test_only_listed_effects_are_built():
    """A world carries exactly the effects its scene lists, and wrench input only if taken."""
    only_gravity = scene_with(lambda d: (d['effects'].pop('damping'),
                                         d['effects'].pop('springs'),
                                         [b.update(wrench_input=False) for b in d['bodies']]))
    assert effect_kinds(build_world(parse_scene(only_gravity))) == [Gravity.__name__]
    everything = build_world(parse_scene(copy.deepcopy(VALID)))
    assert effect_kinds(everything) == sorted(
        cls.__name__ for cls in (Gravity, Damping, Springs))
    no_springs = scene_with(put('effects', 'springs', []))
    assert Springs.__name__ not in effect_kinds(build_world(parse_scene(no_springs)))
    torque_free = build_world(load_scene(os.path.join(CONFIG, 'scenes', 'torque_free.yaml')))
    assert torque_free.effects == []


def test_wrench_input_mask_reaches_the_effect():
    """A body with wrench_input false is refused a wrench; the others accept one."""
    data = scene_with(lambda d: d['bodies'][1].update(wrench_input=False))
    wrenches = build_world(parse_scene(data)).inputs
    assert list(wrenches.accepts_wrench) == [True, False]
    assert wrenches.max_force == 100.0 and wrenches.max_torque == 10.0


def test_initial_body_frame_pose_and_twist_with_offset_centre_of_mass():
    """The body frame's pose and twist come back out although the state is about the CoM.

    Rigid-body velocity field: v_com = v_origin + omega x (R c), P = M v_com.
    """
    origin, quaternion = [0.3, -0.2, 1.0], Rotation.from_euler('xyz', [0.3, -0.5, 1.1])
    v_origin, omega = [0.5, -1.0, 0.25], [1.0, -2.0, 3.0]
    data = {'bodies': [{
        'name': 'l_block', 'shape': {'type': 'mesh', 'file': L_BLOCK, 'scale': 2.0},
        'density': 500.0, 'pose': {'position': origin, 'orientation': list(quaternion.as_quat())},
        'twist': {'linear': v_origin, 'angular': omega}}]}
    world = build_world(parse_scene(data))
    snapshot = world.snapshot()
    position, orientation = snapshot.body_frame_pose()
    velocity, angular_velocity = snapshot.body_frame_twist()
    np.testing.assert_allclose(position[0], origin, atol=1e-12)
    assert abs(np.dot(orientation[0], quaternion.as_quat())) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(velocity[0], v_origin, atol=1e-12)
    np.testing.assert_allclose(angular_velocity[0], omega, atol=1e-12)
    com_offset = quaternion.apply(2.0 * L_BLOCK_COM)
    mass = 500.0 * 8 * 0.004  # density x (scale^3 x unit volume 0.004 m^3)
    np.testing.assert_allclose(world.y[0, :3], np.add(origin, com_offset), atol=1e-9)
    np.testing.assert_allclose(world.y[0, 7:10],
                               mass * (np.add(v_origin, np.cross(omega, com_offset))),
                               rtol=1e-9)


def test_non_unit_quaternion_is_normalised():
    """A quaternion's direction is the rotation; its length carries no meaning."""
    data = scene_with(lambda d: d['bodies'][0]['pose'].update(orientation=[0.0, 0.0, 3.0, 4.0]))
    np.testing.assert_allclose(parse_scene(data).bodies[0].orientation, [0, 0, 0.6, 0.8])


def test_mesh_path_is_relative_to_the_scene_file(tmp_path, monkeypatch):
    """A mesh named relative to its scene loads from any working directory."""
    (tmp_path / 'scenes').mkdir()
    (tmp_path / 'meshes').mkdir()
    shutil.copy(L_BLOCK, tmp_path / 'meshes' / 'part.obj')
    scene_file = tmp_path / 'scenes' / 'part.yaml'
    scene_file.write_text('bodies:\n  - {name: part, mass: 1.0,\n'
                          '     shape: {type: mesh, file: ../meshes/part.obj}}\n')
    monkeypatch.chdir(tmp_path)
    body = load_scene(str(scene_file)).bodies[0]
    np.testing.assert_allclose(body.mass_properties.center_of_mass, L_BLOCK_COM, atol=1e-9)
    scene_file.write_text('bodies:\n  - {name: part, mass: 1.0,\n'
                          '     shape: {type: mesh, file: meshes/part.obj}}\n')
    with pytest.raises(SceneError, match=r'part\.yaml: bodies\[0\]\.shape\.file: mesh not found'):
        load_scene(str(scene_file))


def put(*path_and_value):
    """Return a change that sets ``data[path...] = value``, making missing mappings on the way."""
    *path, key, value = path_and_value

    def change(data):
        for step in path:
            data = data[step] if isinstance(data, list) else data.setdefault(step, {})
        data[key] = value
    return change


def drop(*path):
    """Return a change that deletes ``data[path...]``."""
    def change(data):
        for step in path[:-1]:
            data = data[step]
        del data[path[-1]]
    return change


B0, SPRING0, SPRING1 = ('bodies', 0), ('effects', 'springs', 0), ('effects', 'springs', 1)
MISTAKES = [  # (change, key path named, reason)
    (put('colour', 'red'), 'colour', 'unknown key; valid keys: .*bodies'),
    (put(*B0, 'colour', 'red'), 'bodies[0].colour', 'unknown key; valid keys: .*mass'),
    (put(*B0, 'shape', 'colour', 1), 'bodies[0].shape.colour', "unknown key.*size"),
    (put('effects', 'wind', {}), 'effects.wind', 'unknown key; valid keys: .*gravity'),
    (put(*SPRING0, 'colour', 1), 'effects.springs[0].colour', 'unknown key.*stiffness'),
    (put('limits', 'max_speed', 1.0), 'limits.max_speed', 'unknown key.*max_force'),
    (put(*B0, 'pose', 'position', 1.0), 'bodies[0].pose.position', 'list of 3 numbers'),
    (put(*B0, 'pose', 'position', [1.0, 2.0]), 'bodies[0].pose.position', 'list of 3'),
    (put(*B0, 'twist', 'angular', [0, 0, 'fast']), 'bodies[0].twist.angular[2]',
     'expected a number'),
    (put(*B0, 'mass', '2.0'), 'bodies[0].mass', 'expected a number, got a text of 3 characters'),
    (put(*B0, 'mass', '1e4'), 'bodies[0].mass', 'unquoted: 1.0e4'),
    (put(*B0, 'mass', True), 'bodies[0].mass', 'expected a number, got the boolean'),
    (put(*B0, 'mass', float('nan')), 'bodies[0].mass', 'must be finite'),
    (put(*B0, 'pose', 'position', [0, float('inf'), 0]), 'bodies[0].pose.position[1]',
     'must be finite'),
    (put(*B0, 'mass', 0.0), 'bodies[0].mass', 'must be positive'),
    (put(*B0, 'mass', -2.0), 'bodies[0].mass', 'must be positive'),
    (put('bodies', 1, 'density', -1.0), 'bodies[1].density', 'must be positive'),
    (drop(*B0, 'mass'), 'bodies[0].mass', 'exactly one of mass .* or density'),
    (put(*B0, 'density', 10.0), 'bodies[0].mass', 'exactly one of mass'),
    (drop('bodies'), 'bodies', 'missing required key'),
    (drop(*B0, 'name'), 'bodies[0].name', 'missing required key'),
    (drop(*B0, 'shape'), 'bodies[0].shape', 'missing required key'),
    (put('bodies', []), 'bodies', 'non-empty list'),
    (put('bodies', 1, 'name', 'box'), 'bodies[1].name', r"duplicate body name 'box'"),
    (put(*B0, 'name', 'my box'), 'bodies[0].name', 'topic and frame name'),
    (put(*SPRING0, 'body', 'crate'), 'effects.springs[0].body', "no body named 'crate'"),
    (put(*SPRING1, 'other', 'crate'), 'effects.springs[1].other', "no body named 'crate'"),
    (put(*SPRING0, 'other', 'ball'), 'effects.springs[0]', 'exactly one of anchor .* or other'),
    (drop(*SPRING1, 'other'), 'effects.springs[1]', 'exactly one of anchor'),
    (put(*SPRING0, 'anchor', [0.2, 0.0, 1.0]), 'effects.springs[0]',
     r'both ends at \[0.2, 0.0, 1.0\]: with rest_length 0.1'),
    (put(*SPRING0, 'stiffness', -1.0), 'effects.springs[0].stiffness', 'must be non-negative'),
    (put(*SPRING0, 'damping', -0.1), 'effects.springs[0].damping', 'must be non-negative'),
    (put(*SPRING0, 'rest_length', -0.1), 'effects.springs[0].rest_length', 'non-negative'),
    (put('effects', 'damping', 'linear', -0.1), 'effects.damping.linear', 'non-negative'),
    (put('world_frame', 'ball'), 'bodies[1].name', "body name 'ball' is the world_frame"),
    (put(*B0, 'points', 'ball', [0, 0, 0]), 'bodies[0].points.ball', 'already a frame name'),
    (put(*B0, 'points', 'world', [0, 0, 0]), 'bodies[0].points.world',
     "point 'world' of body 'box' is named like the world_frame"),
    (put(*B0, 'pose', 'orientation', [0, 0, 0, 0]), 'bodies[0].pose.orientation',
     'zero quaternion'),
    (put(*B0, 'pose', 'orientation', [0, 0, 1]), 'bodies[0].pose.orientation', 'list of 4'),
    (put(*B0, 'shape', 'type', 'cone'), 'bodies[0].shape.type',
     "type in .*'box'.*got a text of 4 characters"),
    (drop(*B0, 'shape', 'type'), 'bodies[0].shape.type', 'type in .*got nothing'),
    (put(*B0, 'shape', 'radius', 0.1), 'bodies[0].shape.radius',
     "valid keys: \\('type', 'size'\\)"),
    (put(*B0, 'shape', 'size', [0.4, 0.0, 0.1]), 'bodies[0].shape.size[1]', 'positive'),
    (put(*B0, 'shape', {'type': 'mesh', 'file': 'no_such.stl'}), 'bodies[0].shape.file',
     'mesh not found'),
    (put(*B0, 'inertia', {'method': 'guess'}), 'bodies[0].inertia.method',
     "expected one of .*'exact'.*got a text of 5 characters"),
    (put(*B0, 'inertia', {'diagonal': [0.01, 0.01, 0.05]}), 'bodies[0].inertia.diagonal',
     'triangle inequality'),
    (put(*B0, 'inertia', {'diagonal': [-0.01, 0.02, 0.02]}), 'bodies[0].inertia.diagonal',
     'not positive definite'),
    (put(*B0, 'inertia', {'method': 'given', 'matrix': [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]}),
     'bodies[0].inertia.matrix', 'not symmetric'),
    (put(*B0, 'inertia', {'matrix': [[1, 0, 0], [0, 1, 0]]}), 'bodies[0].inertia.matrix',
     '3 rows of 3 numbers'),
    (put(*B0, 'inertia', {'method': 'given'}), 'bodies[0].inertia', 'exactly one of diagonal'),
    (put(*B0, 'inertia', {'given': {'diagonal': [0.01, 0.01, 0.05]}}),
     'bodies[0].inertia.given.diagonal', 'triangle inequality'),
    (put(*B0, 'inertia', {'given': {}}), 'bodies[0].inertia.given', 'got neither'),
    (put(*B0, 'inertia', {'given': {}, 'diagonal': [1, 1, 1]}), 'bodies[0].inertia.given',
     'got neither'),
    (put(*B0, 'inertia', {'method': 'exact', 'given': {'diagonal': [1, 1, 1]}}),
     'bodies[0].inertia.given', 'no method, diagonal or matrix beside it'),
    (put(*B0, 'inertia', {'diagonal': [1, 1, 1], 'given': {'diagonal': [1, 1, 1]}}),
     'bodies[0].inertia.given', 'no method, diagonal or matrix beside it'),
    (put(*B0, 'inertia', {'method': 'sampling', 'samples': 0}), 'bodies[0].inertia.samples',
     'must be positive'),
    (put(*B0, 'inertia', {'method': 'sampling', 'samples': 10.5}), 'bodies[0].inertia.samples',
     'whole number'),
    (put(*B0, 'inertia', {'method': 'sampling'}), 'bodies[0].inertia.samples', 'needs samples'),
    (put(*B0, 'inertia', {'method': 'exact', 'samples': 8}), 'bodies[0].inertia.samples',
     'others take none'),
    (put(*B0, 'wrench_input', 'yes'), 'bodies[0].wrench_input', 'expected true or false'),
    (put('limits', 'max_force', 0.0), 'limits.max_force', 'must be positive'),
    (put('limits', 'max_torque', -5.0), 'limits.max_torque', 'must be positive'),
    (put('effects', 'gravity', 'acceleration', [0.0, -9.81]), 'effects.gravity.acceleration',
     'list of 3 numbers'),
    (put('effects', 'gravity', 'acceleration', -9.81), 'effects.gravity.acceleration',
     'list of 3 numbers'),
    (put('effects', 'springs', {'body': 'box'}), 'effects.springs', 'list of springs'),
]


@pytest.mark.parametrize('change, key, reason', MISTAKES,
                         ids=[f'{key}:{reason[:20]}' for _, key, reason in MISTAKES])
def test_mistake_names_file_key_and_reason(change, key, reason):
    """A scene with a mistake is refused with '<file>: <key>: <reason>'."""
    with pytest.raises(SceneError, match=f'^bad\\.yaml: {re.escape(key)}: .*(?:{reason})'):
        parse_scene(scene_with(change), path='bad.yaml')


@pytest.mark.parametrize('text, key, reason', [
    ('bodies:\n  - name: box\n    shape: {type: box\n', 'line 4',
     "invalid YAML: (did not find )?expected ',' or '}'"),
    ('bodies: []\nbodies: []\n', 'line 2', 'invalid YAML: duplicate key'),
    ('bodies:\n  - {name: a, mass: 1, mass: 2}\n', 'line 2', 'duplicate key'),
    ('- name: box\n', '(document)', 'expected a mapping .*bodies.*got a list'),
    ('42\n', '(document)', 'expected a mapping .*got a number'),
    ('', '(document)', 'expected a mapping .*got nothing'),
], ids=['syntax', 'duplicate', 'nested-duplicate', 'list', 'scalar', 'empty'])
def test_unreadable_file_is_refused(tmp_path, text, key, reason):
    """A file that is not YAML, repeats a key, or is not a mapping is refused with where."""
    path = tmp_path / 'broken.yaml'
    path.write_text(text)
    with pytest.raises(SceneError, match=f'broken\\.yaml: {re.escape(key)}.*: .*{reason}'):
        load_scene(str(path))


def test_missing_file_is_refused(tmp_path):
    """A scene file that does not exist is a SceneError naming it."""
    with pytest.raises(SceneError, match='nowhere\\.yaml: \\(file\\): scene file not found'):
        load_scene(str(tmp_path / 'nowhere.yaml'))


@pytest.mark.parametrize('frame_id, expected', [
    ('world', ('world', None)), ('', ('body', None)), ('box', ('body', None)),
    ('box/thruster', ('point', [0.2, 0.0, 0.0]))])
def test_wrench_target_maps_frame_ids(frame_id, expected):
    """frame_id picks the axes and the point a wrench acts at, as the README tabulates."""
    box = parse_scene(copy.deepcopy(VALID)).bodies[0]
    frame, point = wrench_target(box, frame_id, 'world')
    assert frame == expected[0]
    assert (point is None) == (expected[1] is None)
    if point is not None:
        np.testing.assert_array_equal(point, expected[1])


@pytest.mark.parametrize('frame_id, reason', [
    ('box/nozzle', "unknown frame_id 'box/nozzle' .*'box/thruster'"),
    ('ball', "unknown frame_id 'ball' for body 'box'"),
    ('map', "unknown frame_id 'map'.*valid: \\['world', '', 'box'")])
def test_wrench_target_refuses_unknown_frames(frame_id, reason):
    """An unknown frame is named, with the frame ids that would be valid."""
    with pytest.raises(ValueError, match=reason):
        wrench_target(parse_scene(copy.deepcopy(VALID)).bodies[0], frame_id, 'world')


@pytest.mark.parametrize('world_frame, body', [('box', 'box'), ('box/thruster', 'box'),
                                               ('thruster', 'box'), ('ball', 'ball')])
def test_world_frame_naming_a_body_frame_is_refused(world_frame, body):
    """A world_frame that is also a body or point name would give frame_id two meanings."""
    scene = parse_scene(copy.deepcopy(VALID))
    with pytest.raises(ValueError, match=f"world_frame '{world_frame}' is a frame of body "
                                         f"'{body}'"):
        check_world_frame(scene, world_frame)
    check_world_frame(scene, 'map')   # any other name is fine


# Names of the VALID scene's frames ('box' has the point 'thruster'), and names that are not.
CLASHING = ['box', 'ball', 'thruster', 'box/thruster']
FREE = ['map', 'odom', 'ball/thruster', 'box/nozzle']


@pytest.mark.parametrize('name', CLASHING + FREE)
def test_scene_loader_and_runtime_world_frame_refuse_the_same_names(name):
    """The loader and the world_frame parameter refuse a name exactly when it is a frame.

    A scene's own world_frame is one name token, so names with a / are compared at runtime
    only; every other name is refused by both or by neither.
    """
    scene = parse_scene(copy.deepcopy(VALID))
    runtime_refused = True
    try:
        check_world_frame(scene, name)
    except ValueError:
        pass
    else:
        runtime_refused = False
    assert runtime_refused == (name in CLASHING)
    if '/' in name:
        return
    loader_refused = True
    try:
        parse_scene(scene_with(put('world_frame', name)), path='bad.yaml')
    except SceneError as error:
        assert 'world_frame' in str(error)
    else:
        loader_refused = False
    assert loader_refused == runtime_refused


def test_open_mesh_is_refused(tmp_path):
    """An open mesh bounds no volume, so it has no mass properties: the shape is refused."""
    mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    mesh.update_faces(np.arange(len(mesh.faces)) > 0)  # drop one triangle: a hole
    mesh.export(tmp_path / 'open.stl')
    data = {'bodies': [{'name': 'shell', 'mass': 1.0,
                        'shape': {'type': 'mesh', 'file': 'open.stl'}}]}
    with pytest.raises(SceneError, match=r'^s\.yaml: bodies\[0\]\.shape: .*not watertight'):
        parse_scene(data, 's.yaml', base_dir=str(tmp_path))


@pytest.mark.parametrize('name, text', [
    ('short_vertex.obj', 'v 1 2\nf 1 2 3\n'),
    ('no_y.ply', 'ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n'
                 '1\n2\n3\n'),
])
def test_malformed_mesh_file_is_refused_by_name(tmp_path, name, text):
    """A mesh file its reader cannot parse is a scene mistake naming the file, not a crash."""
    (tmp_path / name).write_text(text)
    data = {'bodies': [{'name': 'part', 'mass': 1.0, 'shape': {'type': 'mesh', 'file': name}}]}
    with pytest.raises(SceneError, match=rf'^s\.yaml: bodies\[0\]\.shape: cannot read mesh '
                                         rf'file .*{re.escape(name)}'):
        parse_scene(data, 's.yaml', base_dir=str(tmp_path))
