# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Fuzzing the scene loader: wrong values in every field, garbage files, hostile structure.

Every input either builds a world whose state stays finite for a few steps, or is refused
with a SceneError naming the file, a key and a reason; nothing else may come out (no
RecursionError, MemoryError, numpy warning or trimesh exception). See ``fuzzing`` for the
settings (derandomised in CI).
"""
import copy
import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import yaml
from hypothesis import given, strategies as st

from fuzzing import fuzz
from rigid_sim.core.scene import build_world, load_scene, parse_scene, SceneError

L_BLOCK = Path(__file__).resolve().parents[1] / 'config' / 'meshes' / 'l_block.obj'
FUZZ = fuzz(150)
# Every kind of field the format has, each with a value of its kind.
VALID = {
    'world_frame': 'world',
    'limits': {'max_force': 100.0, 'max_torque': 10.0, 'max_bodies': 10, 'max_samples': 4096,
               'max_mesh_bytes': 1 << 20, 'max_mesh_faces': 1000},
    'effects': {
        'gravity': {'acceleration': [0.0, 0.0, -9.81]},
        'damping': {'linear': 0.1, 'angular': 0.1},
        'springs': [{'body': 'box', 'point': [0.2, 0.0, 0.0], 'anchor': [0.0, 0.0, 1.0],
                     'stiffness': 50.0, 'damping': 0.5, 'rest_length': 0.1},
                    {'body': 'box', 'other': 'ball', 'other_point': [0.0, 0.0, 0.1],
                     'stiffness': 10.0}]},
    'bodies': [
        {'name': 'box', 'shape': {'type': 'box', 'size': [0.4, 0.2, 0.1]}, 'mass': 2.0,
         'inertia': {'method': 'sampling', 'samples': 512},
         'pose': {'position': [0.0, 0.0, 1.0], 'orientation': [0.0, 0.0, 0.0, 1.0]},
         'twist': {'linear': [0.1, 0.0, 0.0], 'angular': [0.0, 0.0, 1.0]},
         'points': {'thruster': [0.2, 0.0, 0.0]}, 'wrench_input': True},
        {'name': 'ball', 'shape': {'type': 'sphere', 'radius': 0.1}, 'density': 1000.0,
         'inertia': {'given': {'diagonal': [0.004, 0.004, 0.004]}}},
        {'name': 'can', 'shape': {'type': 'cylinder', 'radius': 0.1, 'length': 0.3},
         'mass': 1.0, 'inertia': {'method': 'bounding_box'}},
        {'name': 'part', 'shape': {'type': 'mesh', 'file': 'part.obj', 'scale': 1.0},
         'mass': 1.0, 'inertia': {'matrix': [[0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]}}],
}


def paths(value, prefix=()):
    """Every path into ``value`` (mapping keys and list indices), the value's own first."""
    yield prefix
    children = value.items() if isinstance(value, dict) else (
        enumerate(value) if isinstance(value, list) else ())
    for key, child in children:
        yield from paths(child, prefix + (key,))


FIELDS = list(paths(VALID))[1:]
NUMBERS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True),
    st.integers(min_value=-10 ** 30, max_value=10 ** 30),
    st.sampled_from([1e200, -1e300, 5e-324, 0.0, -0.0, 1e15, 1e16, 10 ** 400]))
SCALARS = st.one_of(NUMBERS, st.none(), st.booleans(), st.text(max_size=40),
                    st.sampled_from(['1e4', 'box', 'world', '', '../../../etc/passwd']))
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=5)
                      | st.dictionaries(st.text(max_size=10), inner, max_size=4),
                      max_leaves=12)


def key_text(path):
    return ''.join(f'[{step}]' if isinstance(step, int) else f'.{step}' for step in path)[1:]


def replaced(path, value):
    data = copy.deepcopy(VALID)
    target = data
    for step in path[:-1]:
        target = target[step]
    target[path[-1]] = value
    return data


def check_outcome(load):
    """Run ``load()``: a world that steps finitely, or a SceneError with file, key, reason."""
    with warnings.catch_warnings():
        warnings.simplefilter('error', RuntimeWarning)   # overflow is a refusal, not a warning
        try:
            scene = load()
        except SceneError as error:
            assert error.key and error.reason and str(error).startswith(
                str(error.path)[:40]), str(error)
            assert len(str(error)) < 3000
            return error
        world = build_world(scene)
        for _ in range(3):
            world.step(0.01)
        assert np.all(np.isfinite(world.y)) and math.isfinite(world.energy())
        return None


def test_valid_fuzz_base_scene_builds(tmp_path):
    """The base scene is valid, so each refusal below is the replaced field's doing."""
    shutil.copy(L_BLOCK, tmp_path / 'part.obj')
    assert check_outcome(lambda: parse_scene(copy.deepcopy(VALID), 's.yaml', str(tmp_path))) \
        is None


@FUZZ
@given(field=st.sampled_from(FIELDS), value=VALUES)
def test_any_value_in_any_field_builds_or_is_refused_naming_the_field(tmp_path, field, value):
    """A wrong value in a number field is named by that field's own key."""
    if not (tmp_path / 'part.obj').exists():
        shutil.copy(L_BLOCK, tmp_path / 'part.obj')
    error = check_outcome(lambda: parse_scene(replaced(field, value), 's.yaml', str(tmp_path)))
    numeric = isinstance(_at(VALID, field), float)
    if numeric and (isinstance(value, bool) or not isinstance(value, (int, float))):
        assert error is not None and error.key == key_text(field), (field, value, error)


def _at(data, path):
    for step in path:
        data = data[step]
    return data


@FUZZ
@given(data=st.binary(max_size=400))
def test_random_bytes_load_or_are_refused(tmp_path, data):
    path = tmp_path / 'garbage.yaml'
    path.write_bytes(data)
    check_outcome(lambda: load_scene(str(path)))


@FUZZ
@given(document=VALUES)
def test_random_yaml_documents_load_or_are_refused(tmp_path, document):
    path = tmp_path / 'random.yaml'
    path.write_text(yaml.safe_dump({'bodies': document} if isinstance(document, list)
                                   else document))
    assert check_outcome(lambda: load_scene(str(path))) is not None


@FUZZ
@given(depth=st.integers(1, 5000), flow=st.booleans(), mapping=st.booleans())
def test_any_nesting_is_refused_or_loaded_without_recursing(tmp_path, depth, flow, mapping):
    """Nests of every depth and style; the bound is checked on events, never recursing."""
    if flow:
        text = 'bodies: ' + ('{a: ' if mapping else '[') * depth + '1' + \
            ('}' if mapping else ']') * depth
    else:
        text = 'bodies:\n' + ''.join('  ' * (i + 1) + ('a:' if mapping else '-') + '\n'
                                     for i in range(depth))
    path = tmp_path / 'nest.yaml'
    path.write_text(text)
    assert check_outcome(lambda: load_scene(str(path))) is not None


@FUZZ
@given(fanout=st.integers(2, 40), levels=st.integers(1, 12))
def test_alias_bombs_of_any_shape_are_refused_or_small(tmp_path, fanout, levels):
    """Refuse aliases of aliases past the node limit, and never expand them.

    Smaller ones load, and are then refused as no scene.
    """
    lines = [f'l0: &l0 [{", ".join(["x"] * fanout)}]']
    lines += [f'l{i}: &l{i} [{", ".join([f"*l{i - 1}"] * fanout)}]' for i in range(1, levels)]
    path = tmp_path / 'bomb.yaml'
    path.write_text('\n'.join(lines) + f'\nbodies: *l{levels - 1}\n')
    error = check_outcome(lambda: load_scene(str(path)))
    assert error is not None
    if fanout ** levels > 2_000_000:
        assert 'YAML nodes' in error.reason
