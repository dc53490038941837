# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Models of one link as scene bodies, and the directories files are read from (core only).

The node's side of both is tested over DDS in test_spawn_files.py; here the conversions are
checked against the rotations and closed forms written out by hand, and the confinement
against links and ``..`` made on disk.
"""
import math
import os

import numpy as np
import pytest

from rigid_sim.core.robot_description import (
    DescriptionRefused, find_resource, model_body, spawn_format)
from rigid_sim.core.scene import load_scene, SceneError
from rigid_sim.core.scene_file import confined, FileRefused, parse_yaml

YAWED = """<robot name="r"><link name="l">
  <inertial><origin xyz="0.1 0.2 0.3" rpy="0 0 1.5707963267948966"/><mass value="2"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/></inertial>
  <visual><geometry><box size="1 2 3"/></geometry></visual>
</link></robot>"""


def test_a_urdf_inertia_is_turned_into_the_link_axes_and_its_origin_is_the_centre_of_mass():
    """Yawed 90 degrees: the link's x is the inertial frame's -y, so I_xx = iyy, I_yy = ixx."""
    entry, com = model_body(YAWED, 'urdf', lambda uri: uri)
    np.testing.assert_allclose(entry['inertia']['matrix'], np.diag([2.0, 1.0, 3.0]),
                               atol=1e-15)
    assert (entry['name'], entry['mass'], com.tolist()) == ('r', 2.0, [0.1, 0.2, 0.3])
    assert entry['shape'] == {'type': 'box', 'size': [1.0, 2.0, 3.0]}


def test_an_sdf_link_is_placed_by_the_model_and_link_poses():
    """Model yawed 90 degrees at (1, 0, 0), link at (1, 0, 0) of it: (1, 1, 0), yawed.

    A roll of 90 degrees of the inertial frame turns its y into the link's z.
    """
    text = """<sdf version="1.9"><model name="m"><pose>1 0 0 0 0 1.5707963267948966</pose>
      <link name="l"><pose>1 0 0 0 0 0</pose>
        <inertial><pose>0 0 0 1.5707963267948966 0 0</pose><mass>1</mass>
          <inertia><ixx>1</ixx><iyy>2</iyy><izz>3</izz></inertia></inertial>
        <collision name="c"><geometry><sphere><radius>0.5</radius></sphere></geometry>
        </collision></link></model></sdf>"""
    entry, com = model_body(text, 'sdf', lambda uri: uri)
    np.testing.assert_allclose(entry['pose']['position'], [1.0, 1.0, 0.0], atol=1e-15)
    half = math.sqrt(0.5)
    np.testing.assert_allclose(entry['pose']['orientation'], [0.0, 0.0, half, half],
                               atol=1e-15)
    np.testing.assert_allclose(entry['inertia']['matrix'], np.diag([1.0, 3.0, 2.0]),
                               atol=1e-15)
    assert com.tolist() == [0.0, 0.0, 0.0]
    assert entry['shape'] == {'type': 'sphere', 'radius': 0.5}


@pytest.mark.parametrize('text, name, expected', [
    ('{name: a}', '', 'rigid_sim_yaml'), ('<robot name="r"/>', '', 'urdf'),
    ('<sdf version="1.9"/>', '', 'sdf'), ('', 'a.URDF', 'urdf'), ('x', 'b.sdf', 'sdf'),
    ('<robot/>', 'c.yaml', 'rigid_sim_yaml')])
def test_the_format_is_told_by_the_file_ending_else_by_the_root_element(
        text, name, expected):
    assert spawn_format(text, name) == expected


@pytest.mark.parametrize('text, name', [
    ('<mujoco/>', ''), ('<COLLADA/>', ''), ('<robot/>', 'a.xacro'), ('', 'w.world'),
    ('<html/>', '')])
def test_formats_not_served_are_told_apart_from_malformed_ones(text, name):
    with pytest.raises(DescriptionRefused) as refused:
        spawn_format(text, name)
    assert refused.value.kind == 'unsupported'


def test_xml_with_a_doctype_or_malformed_is_refused_by_position_without_its_text():
    secret = 'TOPSECRET_7f3a'
    for text in (f'<!DOCTYPE r [<!ENTITY e "{secret}">]><robot name="&e;"/>',
                 f'<robot name="{secret}"><link></robot>'):
        with pytest.raises(DescriptionRefused) as refused:
            spawn_format(text)
        assert refused.value.kind == 'parse' and secret not in str(refused.value)


def test_reads_are_confined_through_links_and_dotdot(tmp_path):
    """A link out, ``..`` out and a missing file get the same words; a link within is read."""
    inside, outside = tmp_path / 'inside', tmp_path / 'outside'
    inside.mkdir()
    outside.mkdir()
    (outside / 'secret').write_text('x')
    (inside / 'out').symlink_to(outside / 'secret')
    (inside / 'real').write_text('y')
    (inside / 'in').symlink_to(inside / 'real')
    roots = [str(inside)]
    answers = set()
    for path in (inside / 'out', inside / '..' / 'outside' / 'secret', outside / 'secret',
                 inside / 'missing', '/etc/passwd', 'a\0b'):
        with pytest.raises(FileRefused) as refused:
            confined(path, roots, 'file')
        answers.add(str(refused.value))
    assert len(answers) == 1
    assert confined(inside / 'in', roots, 'file') == str(inside / 'real')


def test_a_scene_and_its_meshes_are_confined_and_a_package_uri_is_looked_up_in_the_roots(
        tmp_path):
    root = tmp_path / 'root'
    (root / 'pkg' / 'meshes').mkdir(parents=True)
    (root / 'pkg' / 'meshes' / 'm.obj').write_text('v 0 0 0\n')
    found = find_resource('package://pkg/meshes/m.obj', '.', [str(root)], 'mesh')
    assert found == str(root / 'pkg' / 'meshes' / 'm.obj')
    with pytest.raises(DescriptionRefused) as refused:
        find_resource('package://pkg/../../x', '.', [str(root)], 'mesh')
    assert refused.value.kind == 'missing_asset'
    scene = root / 's.yaml'
    scene.write_text('bodies:\n  - {name: b, mass: 1.0, shape: {type: mesh, file: '
                     f'{tmp_path}/elsewhere.obj}}}}\n')
    (tmp_path / 'elsewhere.obj').write_text('v 0 0 0\n')
    with pytest.raises(SceneError, match='bodies.0..shape.file: mesh not found in the '
                                         'allowed resource directories'):
        load_scene(str(scene), roots=[str(root)])
    with pytest.raises(SceneError, match='scene file not found in the allowed'):
        load_scene(str(scene), roots=[str(tmp_path / 'other')])


@pytest.mark.parametrize('text', [
    'a: *TOPSECRET_7f3a\n', 'a: !TOPSECRET_7f3a 1\n', 'a: "TOPSECRET_7f3a\n',
    '{TOPSECRET_7f3a: 1, TOPSECRET_7f3a: 2}\n', 'a: b: TOPSECRET_7f3a\n'])
def test_yaml_refusals_say_where_and_not_what(text):
    with pytest.raises(FileRefused) as refused:
        parse_yaml(text)
    assert 'TOPSECRET' not in str(refused.value) and 'line' in refused.value.where


def test_a_relative_mesh_path_of_a_model_starts_at_its_file(tmp_path):
    (tmp_path / 'm.obj').write_text('v 0 0 0\n')
    assert find_resource('m.obj', str(tmp_path), [str(tmp_path)], 'mesh') == str(
        tmp_path / 'm.obj')
    assert os.path.isabs(find_resource(f'file://{tmp_path}/m.obj', '.', [str(tmp_path)],
                                       'mesh'))
