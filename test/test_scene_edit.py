# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Bodies added to and removed from a running World: what is carried, what goes with them.

The edit's world is built from the new Scene and given the old one's state, time and held
wrenches; the node side (a worker thread, the swap between two ticks) is tested over DDS in
test_sim_interfaces.py, and here the scene editor's build is checked to run off the executor.
"""
from dataclasses import replace
import threading

import numpy as np
import pytest
import yaml

from rigid_sim.core.integrators import DEFAULT_INTEGRATOR
from rigid_sim.core.scene import build_world, parse_scene
from rigid_sim.core.scene_edit import (
    body_from_text, carry_over, checked_body, entry_from_model, placed, SpawnRefused,
    with_bodies, without_body)

SCENE = """
limits: {max_bodies: 3}
effects:
  gravity: {acceleration: [0.0, 0.0, -9.81]}
  springs:
    - {body: a, anchor: [0.0, 0.0, 2.0], stiffness: 10.0}
    - {body: b, other: c, stiffness: 5.0, rest_length: 1.0}
bodies:
  - {name: a, shape: {type: sphere, radius: 0.1}, mass: 1.0}
  - {name: b, shape: {type: sphere, radius: 0.1}, mass: 1.0, pose: {position: [1.0, 0.0, 0.0]}}
  - {name: c, shape: {type: sphere, radius: 0.1}, mass: 1.0, pose: {position: [2.0, 0.0, 0.0]}}
"""


def running():
    scene = parse_scene(yaml.safe_load(SCENE))
    world = build_world(scene, DEFAULT_INTEGRATOR)
    world.step(0.01)
    world.inputs.hold(2, 'push', 'world', [1.0, 0.0, 0.0], expires=5.0)
    world.inputs.hold(1, 'side', 'point', [0.0, 2.0, 0.0], point=[0.1, 0.0, 0.0])
    return scene, world


def test_removing_a_body_carries_the_others_and_drops_its_springs():
    """Deleting b: its spring to c goes; a's anchor spring stays; c keeps its push."""
    scene, world = running()
    new_scene, dropped = without_body(scene, 1)
    assert dropped == 1 and [b.name for b in new_scene.bodies] == ['a', 'c']
    spring, = new_scene.effects['springs']
    assert (spring.body, spring.other) == (0, None)
    new = build_world(new_scene, DEFAULT_INTEGRATOR)
    carry_over(world, new, [(0, 0), (2, 1)])
    np.testing.assert_array_equal(new.y, world.y[[0, 2]])
    np.testing.assert_array_equal(new.initial, world.initial[[0, 2]])
    assert new.time == world.time
    (key, held), = new.inputs.held.items()
    assert key == (1, 'push') and held.force.tolist() == [1.0, 0.0, 0.0] and held.expires == 5.0


def test_adding_a_body_keeps_every_held_wrench_and_starts_it_at_its_entry():
    scene, world = running()
    spec = body_from_text('{name: d, shape: {type: box, size: [1, 1, 1]}, mass: 6.0}', scene)
    # A 1 m cube of 6 kg: I = m (1 + 1) / 12 = 1 kg m^2 about every axis.
    np.testing.assert_allclose(spec.mass_properties.inertia, np.eye(3), atol=1e-12)
    spec = placed(spec, [0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0])
    roomier = parse_scene(yaml.safe_load(SCENE.replace('max_bodies: 3', 'max_bodies: 4')))
    new = build_world(with_bodies(roomier, [spec]), DEFAULT_INTEGRATOR)
    carry_over(world, new, [(i, i) for i in range(3)])
    np.testing.assert_array_equal(new.y[:3], world.y)
    assert new.y[3, :3].tolist() == [0.0, 0.0, 5.0] and not new.y[3, 7:].any()
    assert new.inputs.held.keys() == world.inputs.held.keys()
    np.testing.assert_allclose(new.net_wrench()[0][:3], world.net_wrench()[0], atol=1e-12)


def test_spawns_are_held_to_the_scene_names_limits_and_poses():
    scene, _ = running()
    spec = body_from_text('{name: d, shape: {type: sphere, radius: 0.1}, mass: 1.0}', scene)
    with pytest.raises(SpawnRefused) as full:
        with_bodies(scene, [spec])
    assert full.value.kind == 'parse' and 'max_bodies' in str(full.value)
    taken = body_from_text('{shape: {type: sphere, radius: 0.1}, mass: 1.0}', scene, name='a')
    roomier = parse_scene(yaml.safe_load(SCENE.replace('max_bodies: 3', 'max_bodies: 4')))
    with pytest.raises(SpawnRefused) as clash:
        with_bodies(roomier, [taken])
    assert clash.value.kind == 'name_taken'
    with pytest.raises(SpawnRefused) as bad:
        body_from_text('{name: e, shape: {type: sphere}, mass: 1.0}', scene)
    assert bad.value.kind == 'parse' and str(bad.value).startswith('resource_string: shape')
    with pytest.raises(SpawnRefused) as turned:
        placed(spec, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.5])
    assert turned.value.kind == 'pose'


def test_a_scene_edit_is_built_off_the_executor_while_the_node_ticks(rigid_sim):
    """While an edit's build waits, the node ticks and answers; then the edit is swapped in."""
    sim = rigid_sim(yaml=SCENE)
    editor = sim.node.sim_interfaces.editor
    release, outcomes = threading.Event(), []

    def build(scene):
        release.wait(30.0)
        new, _ = without_body(scene, 0)
        return new, [(1, 0), (2, 1)], ''
    editor.submit(build, outcomes.append)
    assert sim.step(3) == pytest.approx(3 * sim.node.settings.time_step)   # not stalled
    assert not outcomes and sim.node.world.bodies.names == ('a', 'b', 'c')
    release.set()
    assert editor.wait(30.0)
    assert sim.node.world.bodies.names == ('b', 'c') and outcomes[0][2] == ''


@pytest.mark.parametrize('spawn_format, model', [
    ('urdf', '<robot name="far"><link name="l"><inertial><origin xyz="{x} 0 0"/>'
             '<mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>'
             '</inertial><collision><geometry><sphere radius="0.5"/></geometry></collision>'
             '</link></robot>'),
    ('sdf', '<sdf version="1.9"><model name="far"><link name="l"><inertial>'
            '<pose>{x} 0 0 0 0 0</pose><mass>1</mass><inertia><ixx>1</ixx><iyy>1</iyy>'
            '<izz>1</izz></inertia></inertial><collision name="c"><geometry><sphere>'
            '<radius>0.5</radius></sphere></geometry></collision></link></model></sdf>')])
def test_a_models_centre_of_mass_is_held_to_the_bound_of_scene_numbers(spawn_format, model):
    """A URDF or SDF inertial origin 1e300 m away would overflow the state at the first turn.

    The scene format bounds every number by 1e15 (a shape's centre of mass is inside it);
    a model gives the centre of mass itself, so it is held to the same bound.
    """
    scene, _ = running()
    near = entry_from_model(model.format(x='1000.0'), spawn_format, lambda uri: uri)
    body = checked_body(near[0], scene, center_of_mass=near[1])
    assert body.mass_properties.center_of_mass.tolist() == [1000.0, 0.0, 0.0]
    for far in ('1e16', '1e300'):
        entry, center = entry_from_model(model.format(x=far), spawn_format, lambda uri: uri)
        with pytest.raises(SpawnRefused, match=r'inertial origin \(the centre of mass\)\[0\]: '
                                               r'must be at most 1e\+15') as refused:
            checked_body(entry, scene, center_of_mass=center)
        assert refused.value.kind == 'parse'


def test_spawned_points_count_with_the_scenes_towards_max_points():
    """A spawn flood of bodies with points would make every swap's /tf_static grow without end.

    The running scene's points and the spawned body's together are held to max_points.
    """
    scene, _ = running()
    scene = replace(scene, work_limits={**scene.work_limits, 'max_bodies': 9, 'max_points': 3})
    two = ('{name: %s, shape: {type: sphere, radius: 0.1}, mass: 1.0, '
           'points: {p: [0, 0, 0], q: [0, 0, 0]}}')
    first = body_from_text(two % 'd', scene)
    scene = with_bodies(scene, [first])
    with pytest.raises(SpawnRefused, match=r'2 named points and 2 more are above the scene '
                                           r'limit of 3 \(limits.max_points\)'):
        with_bodies(scene, [body_from_text(two % 'e', scene)])
    one = '{name: e, shape: {type: sphere, radius: 0.1}, mass: 1.0, points: {p: [0, 0, 0]}}'
    assert with_bodies(scene, [body_from_text(one, scene)]).bodies[-1].name == 'e'
