# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Scene loading is bounded and total: every hostile file is refused, naming file and reason.

Each limit is reached by a file made here, and refused before the work it guards (a sparse
file of 17 MiB is never read, a trillion samples are never drawn). Numbers read as users
write them (YAML 1.2 floats), and the README's own scene example loads.
"""
import os
import re
import shutil
from pathlib import Path

import pytest

from rigid_sim.core.scene import load_scene, SceneError
from rigid_sim.core.scene_file import MAX_DEPTH, MAX_NODES, MAX_SCENE_BYTES
from rigid_sim.core.scene_limits import WORK_LIMITS

ROOT = Path(__file__).resolve().parents[1]
L_BLOCK = ROOT / 'config' / 'meshes' / 'l_block.obj'
BOX = "{name: %s, mass: 1.0, shape: {type: box, size: [1.0, 1.0, 1.0]}%s}"


def scene_text(extra='', name='b', head=''):
    return f'{head}bodies:\n  - {BOX % (name, extra)}\n'


def refused(path, key, reason):
    """Load ``path`` and check the SceneError is '<path>: <key>: <reason>'."""
    with pytest.raises(SceneError) as caught:
        load_scene(str(path))
    message = str(caught.value)
    assert re.match(f'{re.escape(str(path))}: {key}: .*{reason}', message), message
    return message


@pytest.mark.parametrize('written, expected', [
    ('1e4', 1e4), ('1.0e4', 1e4), ('-2.5E-3', -2.5e-3), ('+3E2', 300.0), ('.5', 0.5)])
def test_numbers_are_read_as_yaml_1_2_and_ros_parameter_files_read_them(
        tmp_path, written, expected):
    """An exponent without a dot is a number, as in YAML 1.2 (YAML 1.1 made it text)."""
    path = tmp_path / 'numbers.yaml'
    path.write_text(scene_text(f', twist: {{linear: [{written}, 0.0, 0.0]}}',
                               head=f'limits: {{max_force: {written.lstrip("-")}}}\n'))
    scene = load_scene(str(path))
    assert scene.bodies[0].linear_velocity[0] == expected
    assert scene.max_force == abs(expected)


def test_readme_scene_example_loads():
    """The scene block of the README is a valid scene (its max_force: 1.0e4 a number)."""
    readme = (ROOT / 'README.md').read_text()
    block = re.search(r'## Scene files.*?```yaml\n(.*?)```', readme, re.S).group(1)
    path = ROOT / 'test' / '.readme_scene.yaml'
    try:
        path.write_text(block)
        scene = load_scene(str(path))
    finally:
        path.unlink()
    assert scene.max_force == 1.0e4 and [body.name for body in scene.bodies] == ['box']


def test_huge_number_is_refused_with_the_reason(tmp_path):
    """1e200 rad/s would overflow the energy: refused naming the component, not warned."""
    path = tmp_path / 'spin.yaml'
    path.write_text(scene_text(', twist: {angular: [0.0, 0.0, 1.0e200]}'))
    refused(path, re.escape('bodies[0].twist.angular[2]'),
            'at most 1e\\+15 in magnitude.*got more')
    path.write_text(scene_text(', pose: {position: [1' + '0' * 40 + ', 0, 0]}'))
    refused(path, re.escape('bodies[0].pose.position[0]'), 'at most 1e\\+15')
    path.write_text(scene_text().replace('mass: 1.0', 'mass: 1.0e-300'))
    refused(path, re.escape('bodies[0].mass'), 'at least 1e-15')


@pytest.mark.parametrize('text, reason', [
    ('bodies: ' + '[' * 100_000 + ']' * 100_000, 'nest'),
    (''.join('  ' * i + '-\n' for i in range(2 * MAX_DEPTH)), 'nested deeper than'),
    ('bodies:\n' + ''.join(f'{"  " * i}- x: \n' for i in range(MAX_DEPTH)), 'nested deeper'),
], ids=['flow-100000', 'block-lists', 'block-mappings'])
def test_deep_nesting_is_refused_without_recursing(tmp_path, text, reason):
    """Nesting far past anything a scene needs is refused at the first too-deep level."""
    path = tmp_path / 'deep.yaml'
    path.write_text(text)
    refused(path, 'line \\d+, column \\d+', reason)


def test_alias_bomb_is_refused_before_it_expands(tmp_path):
    """Ten aliases of ten aliases, nine levels deep, would be 1e10 nodes."""
    lines = ['a0: &a0 [x, x, x, x, x, x, x, x, x, x]']
    lines += [f'a{i}: &a{i} [{", ".join([f"*a{i - 1}"] * 10)}]' for i in range(1, 10)]
    path = tmp_path / 'bomb.yaml'
    path.write_text('\n'.join(lines) + '\nbodies: *a9\n')
    refused(path, 'line \\d+, column \\d+', f'more than {MAX_NODES} YAML nodes')


def test_non_utf8_scene_is_refused_naming_the_byte(tmp_path):
    path = tmp_path / 'latin1.yaml'
    path.write_bytes(scene_text().encode() + '# caf\xe9\n'.encode('latin-1'))
    refused(path, 'byte \\d+', 'not UTF-8 text')


def test_control_character_and_oversized_integer_are_refused(tmp_path):
    path = tmp_path / 'control.yaml'
    path.write_text(scene_text() + '\x00')
    refused(path, 'character \\d+', 'unacceptable character')
    path.write_text(scene_text().replace('mass: 1.0', 'mass: ' + '9' * 5000))
    refused(path, re.escape('(file)'), 'invalid YAML value')


def test_special_files_are_refused_as_not_regular(tmp_path):
    """A FIFO would block the reader, /dev/zero never ends: refused before opening."""
    fifo = tmp_path / 'scene.fifo'
    os.mkfifo(fifo)
    refused(fifo, re.escape('(file)'), 'not a regular file \\(a FIFO\\)')
    refused(Path('/dev/zero'), re.escape('(file)'), 'not a regular file \\(a character device')
    refused(tmp_path, re.escape('(file)'), 'not a regular file \\(a directory\\)')


def test_scene_file_above_the_size_limit_is_refused_unread(tmp_path):
    """A sparse file: its size is all the loader may look at."""
    path = tmp_path / 'huge.yaml'
    with open(path, 'wb') as stream:
        stream.truncate(MAX_SCENE_BYTES + 1)
    refused(path, re.escape('(file)'), f'{MAX_SCENE_BYTES + 1} bytes, above the limit')


def mesh_scene(tmp_path, files, limits=''):
    bodies = ''.join(f'  - {{name: m{i}, mass: 1.0, shape: {{type: mesh, file: {name}}}}}\n'
                     for i, name in enumerate(files))
    path = tmp_path / 'meshes.yaml'
    path.write_text(f'limits: {{{limits}}}\nbodies:\n{bodies}')
    return path


def test_mesh_bytes_are_bounded_per_scene_and_a_shared_mesh_counts_once(tmp_path):
    shutil.copy(L_BLOCK, tmp_path / 'a.obj')
    shutil.copy(L_BLOCK, tmp_path / 'b.obj')
    size = L_BLOCK.stat().st_size
    shared = load_scene(str(mesh_scene(tmp_path, ['a.obj'] * 3, f'max_mesh_bytes: {size}')))
    assert len(shared.bodies) == 3
    refused(mesh_scene(tmp_path, ['a.obj', 'b.obj'], f'max_mesh_bytes: {size}'),
            re.escape('bodies[1].shape.file'), 'above the limit .*max_mesh_bytes')
    with open(tmp_path / 'huge.stl', 'wb') as stream:
        stream.truncate(WORK_LIMITS['max_mesh_bytes'] + 1)
    refused(mesh_scene(tmp_path, ['huge.stl']), re.escape('bodies[0].shape.file'),
            'above the limit')


def test_mesh_faces_and_special_mesh_files_are_refused(tmp_path):
    shutil.copy(L_BLOCK, tmp_path / 'a.obj')
    refused(mesh_scene(tmp_path, ['a.obj'], 'max_mesh_faces: 4'), re.escape('bodies[0].shape'),
            'faces in .*above the limit of 4')
    os.mkfifo(tmp_path / 'pipe.stl')
    refused(mesh_scene(tmp_path, ['pipe.stl']), re.escape('bodies[0].shape.file'),
            'not a regular file \\(a FIFO\\)')
    refused(mesh_scene(tmp_path, ['/dev/zero']), re.escape('bodies[0].shape.file'),
            'not a regular file')


def test_samples_are_refused_before_they_are_drawn(tmp_path):
    """A trillion samples would need ~100 TB; the budget is all bodies' samples together."""
    path = tmp_path / 'samples.yaml'
    sampled = ', inertia: {method: sampling, samples: %s}'
    path.write_text(scene_text(sampled % '1.0e12'))
    refused(path, re.escape('bodies[0].inertia.samples'),
            f'1000000000000 samples.*above the limit of {WORK_LIMITS["max_samples"]}')
    path.write_text(f'limits: {{max_samples: 3000}}\nbodies:\n  - {BOX % ("a", sampled % 2000)}'
                    f'\n  - {BOX % ("b", sampled % 2000)}\n')
    refused(path, re.escape('bodies[1].inertia.samples'), '2000 drawn by earlier bodies')


def test_named_points_are_bounded_for_all_bodies_together(tmp_path):
    """Every named point is a frame of the /tf_static message each scene change publishes.

    Published between two ticks, 100 000 of them held control 2.2 s; 1024 by default, for
    all bodies together, and only the operator raises it.
    """
    path = tmp_path / 'points.yaml'
    many = ', points: {%s}' % ', '.join(f'p{i}: [0.0, 0.0, 0.0]' for i in range(1025))
    path.write_text(scene_text(many))
    refused(path, re.escape('bodies[0].points'), '1025 points, with 0 named by earlier '
                                                 'bodies, is above the limit of 1024')
    assert len(load_scene(str(path), max_points=1025).bodies[0].points) == 1025
    two = ', points: {p: [0.0, 0.0, 0.0], q: [0.1, 0.0, 0.0]}'
    path.write_text(f'limits: {{max_points: 3}}\nbodies:\n  - {BOX % ("a", two)}'
                    f'\n  - {BOX % ("b", two)}\n')
    refused(path, re.escape('bodies[1].points'), '2 points, with 2 named by earlier bodies')


def test_body_count_is_bounded_and_only_the_operator_raises_it(tmp_path):
    """A scene may lower max_bodies; the loader's argument (the node's parameter) raises it."""
    path = tmp_path / 'bodies.yaml'
    bodies = ''.join(f'  - {BOX % (f"b{i}", "")}\n' for i in range(3))
    path.write_text('limits: {max_bodies: 2}\nbodies:\n' + bodies)
    refused(path, 'bodies', "3 bodies, above the limit of 2 \\(the scene's own limits")
    path.write_text('bodies:\n' + bodies)
    with pytest.raises(SceneError, match="3 bodies, above the limit of 2 .*the node's parameter "
                                         'max_bodies raises it'):
        load_scene(str(path), max_bodies=2)
    path.write_text('limits: {max_bodies: 3}\nbodies:\n' + bodies)
    with pytest.raises(SceneError, match=re.escape(
            f"{path}: limits.max_bodies: 3 is above the operator's limit of 2: a scene may "
            "lower its limits, never raise them (the node's parameter max_bodies raises it)")):
        load_scene(str(path), max_bodies=2)
    assert len(load_scene(str(path), max_bodies=3).bodies) == 3


# 150 bytes that asked for 1e8 samples: 45 s and 9.6 GB when a file could raise its limits.
GREEDY = ('limits: {max_samples: 100000000}\nbodies:\n  - {name: b, mass: 1.0, shape: {type: '
          'box, size: [1.0, 1.0, 1.0]}, inertia: {method: sampling, samples: 100000000}}\n')


def test_a_scene_asking_for_more_than_the_operator_allows_is_refused_before_any_work(
        tmp_path, monkeypatch):
    """Its limits: is refused naming the key, both values and the parameter that raises it."""
    def never(*args, **kwargs):
        raise AssertionError('sampled an inertia')
    monkeypatch.setattr('rigid_sim.core.inertia.sampling_estimate', never)
    path = tmp_path / 'greedy.yaml'
    path.write_text(GREEDY)
    assert path.stat().st_size < 160
    message = refused(path, re.escape('limits.max_samples'),
                      f"100000000 is above the operator's limit of {WORK_LIMITS['max_samples']}")
    assert "the node's parameter max_samples raises it" in message
    for name in WORK_LIMITS:   # each limit alike
        path.write_text(f'limits: {{{name}: {WORK_LIMITS[name] + 1}}}\n' + scene_text())
        refused(path, re.escape(f'limits.{name}'), f"above the operator's limit .*{name}")


def test_the_operator_sets_the_file_size_limit_and_no_scene_can_change_it(tmp_path):
    """max_scene_bytes bounds the file before it is read; a scene has no such key."""
    path = tmp_path / 'small.yaml'
    path.write_text(scene_text())
    size = path.stat().st_size
    assert len(load_scene(str(path), max_scene_bytes=size).bodies) == 1
    with pytest.raises(SceneError, match=f"{size} bytes, above the limit of {size - 1} bytes "
                                         ".*the node's parameter max_scene_bytes raises it"):
        load_scene(str(path), max_scene_bytes=size - 1)
    path.write_text(scene_text(head='limits: {max_scene_bytes: 1}\n'))
    refused(path, re.escape('limits.max_scene_bytes'), 'unknown key')


@pytest.mark.parametrize('limits, reason', [
    ({'max_sampels': 10}, 'unknown resource limit'), ({'max_bodies': 0}, 'positive int'),
    ({'max_samples': 1.5}, 'positive int'), ({'max_bodies': True}, 'positive int')])
def test_the_loader_refuses_limits_it_does_not_know(tmp_path, limits, reason):
    path = tmp_path / 'scene.yaml'
    path.write_text(scene_text())
    with pytest.raises(ValueError, match=reason):
        load_scene(str(path), **limits)


def test_yaml_merge_keys_work_as_in_yaml_and_count_towards_the_node_limit(tmp_path):
    """``<<: *defaults`` brings in the anchor's keys, which the keys beside it override.

    A merge repeats its anchor as an alias does, so a file that multiplies a mapping by
    merges is refused by the node count before anything is built.
    """
    path = tmp_path / 'merged.yaml'
    path.write_text('bodies:\n'
                    '  - &box {name: a, mass: 1.0, shape: {type: box, size: [1.0, 1.0, 1.0]}}\n'
                    '  - {<<: *box, name: b, mass: 2.0}\n'
                    '  - {<<: [*box, {pose: {position: [0.0, 0.0, 3.0]}}], name: c}\n')
    a, b, c = load_scene(str(path)).bodies
    assert (b.name, b.mass_properties.mass) == ('b', 2.0)
    assert b.shape['size'].tolist() == a.shape['size'].tolist() == [1.0, 1.0, 1.0]
    assert (c.name, c.mass_properties.mass, c.origin.tolist()) == ('c', 1.0, [0.0, 0.0, 3.0])
    path.write_text('bodies:\n  - &ball {name: a, mass: 1.0, shape: {type: sphere, radius: 1.0}}'
                    '\n  - {<<: *ball, name: b, name: c}\n')   # merged keys aside, none twice
    refused(path, re.escape('line 3, column 26'), 'duplicate key')
    # Ten levels of ten merges of the level below: 10^10 keys, refused at its first levels.
    levels = ['k0: &l0 {x: 1}'] + [
        f'k{i}: &l{i} {{<<: [{", ".join([f"*l{i - 1}"] * 10)}], y{i}: 1}}' for i in range(1, 10)]
    path.write_text('\n'.join(levels) + '\n')
    refused(path, r'line \d+, column \d+', f'more than {MAX_NODES} YAML nodes')


def test_outside_text_in_a_refusal_is_clipped(tmp_path):
    """A 100 kB name is quoted by its ends only; a key that is no name, by its place."""
    path = tmp_path / 'long.yaml'
    path.write_text(scene_text(name='n' * 100_000))
    assert len(refused(path, re.escape('bodies[0].name'), 'at most 100 letters')) < 2000
    path.write_text('? ' + 'k' * 100_000 + '\n: 1\n' + scene_text())
    assert len(refused(path, re.escape('(key 1)'), 'unknown key')) < 2000


@pytest.mark.parametrize('value, words', [
    ('[1, 2]', 'a list of 2'), ('{a: 1}', 'a mapping'), ('2001-01-01', 'a date value'),
    ('null', 'nothing'), ('yes', 'the boolean true'), ('"2.0"', 'a text of 3 characters')])
def test_wrong_types_are_refused_naming_the_key(tmp_path, value, words):
    """Every kind of value where a number belongs is named by what it is."""
    path = tmp_path / 'types.yaml'
    path.write_text(scene_text().replace('mass: 1.0', f'mass: {value}'))
    refused(path, re.escape('bodies[0].mass'), f'expected a number, got .*{re.escape(words)}')
