# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""What SpawnEntity and the scene parameter read, and the URDF and SDFormat they accept.

One ``rigid_sim_node`` process serves the module over DDS, started in a folder of its own
(its working directory, so the one allowed directory besides the packaged config/), on a
scene without effects: a spawned body moves freely, and its motion is judged against the
independent reference of ``rigid_sim.bench.oracles`` (Newton-Euler by DOP853), fed the
mass, centre of mass and inertia the URDF or SDFormat text gives, turned into link axes here.

Files outside the folder hold a marker text: no answer, log line or /diagnostics value may
quote it, and a file there is refused with the words a missing file gets.
"""
import math

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from rcl_interfaces.msg import Log, Parameter as ParameterMessage, ParameterType
from rcl_interfaces.srv import GetParameters, SetParameters
from scipy.spatial.transform import Rotation
from simulation_interfaces.msg import Result, SimulationState
from simulation_interfaces.srv import SpawnEntity

from rigid_sim.bench.oracles import reference_motion
from ros_tools import record, TIMEOUT, spin_until
from sim_client import SimProcess

DT = 0.01
OK = Result.RESULT_OK
CODES = SpawnEntity.Response
SECRET = 'TOPSECRET_7f3a'
SCENE = """
bodies:
  - {name: anchor, shape: {type: box, size: [1.0, 1.0, 1.0]}, mass: 1.0,
     pose: {position: [0.0, 0.0, -10.0]}}
"""
# A unit cube centred at the origin, as an OBJ: closed, so its inertia is defined.
CUBE_OBJ = ''.join(f'v {x} {y} {z}\n' for x in (-0.5, 0.5) for y in (-0.5, 0.5)
                   for z in (-0.5, 0.5)) + """f 2 4 3 1
f 7 8 6 5
f 5 6 2 1
f 4 8 7 3
f 3 7 5 1
f 6 8 4 2
"""
# One link: the inertial frame 0.1 m up the link's z and turned 90 degrees about it, so the
# link's axes see ixx and iyy swapped.
URDF = """<?xml version="1.0"?>
<robot name="can">
  <link name="can_link">
    <inertial>
      <origin xyz="0 0 0.1" rpy="0 0 1.5707963267948966"/>
      <mass value="2.0"/>
      <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.25"/>
    </inertial>
    <collision><geometry><cylinder radius="0.1" length="0.4"/></geometry></collision>
  </link>
</robot>
"""
URDF_MASS, URDF_COM = 2.0, np.array([0.0, 0.0, 0.1])
URDF_INERTIA = np.diag([0.2, 0.1, 0.25])   # diag(0.1, 0.2, 0.25) turned 90 degrees about z
# A brick 0.1 x 0.2 x 0.3 m of 3 kg with its closed-form inertia m (b^2 + c^2) / 12, ...,
# the model placed at (1, 2, 3) turned 90 degrees about z, the link 0.5 m along the
# model's x, the inertial frame at the link frame.
BRICK = (0.1, 0.2, 0.3)
BRICK_MASS = 3.0
BRICK_INERTIA = BRICK_MASS / 12.0 * np.array([BRICK[1] ** 2 + BRICK[2] ** 2,
                                              BRICK[0] ** 2 + BRICK[2] ** 2,
                                              BRICK[0] ** 2 + BRICK[1] ** 2])
SDF = f"""<?xml version="1.0"?>
<sdf version="1.9">
  <model name="brick">
    <pose>1 2 3 0 0 1.5707963267948966</pose>
    <link name="body">
      <pose>0.5 0 0 0 0 0</pose>
      <inertial>
        <mass>{BRICK_MASS}</mass>
        <inertia><ixx>{float(BRICK_INERTIA[0])!r}</ixx><iyy>{float(BRICK_INERTIA[1])!r}</iyy>
          <izz>{float(BRICK_INERTIA[2])!r}</izz></inertia>
      </inertial>
      <collision name="c"><geometry><box><size>0.1 0.2 0.3</size></box></geometry></collision>
    </link>
  </model>
</sdf>
"""
TWO_LINKS = URDF.replace('</robot>', '<link name="second"/></robot>')


@pytest.fixture(scope='module')
def world(tmp_path_factory):
    """Start the node in its folder, with a folder outside holding files it must not read."""
    folder = tmp_path_factory.mktemp('allowed')
    outside = tmp_path_factory.mktemp('outside')
    (folder / 'scene.yaml').write_text(SCENE)
    (outside / 'secret.yaml').write_text(f'{SECRET}\n')
    (outside / 'cube.obj').write_text(CUBE_OBJ)
    (folder / 'cube.obj').write_text(CUBE_OBJ)
    (folder / 'leak.yaml').symlink_to(outside / 'secret.yaml')
    process = SimProcess(str(folder / 'scene.yaml'), f'/sf{id(folder) % 100000}', folder,
                         'rate:=0', 'start_paused:=true')
    process.folder, process.outside = folder, outside
    process.logs = record(process.node, Log, '/rosout')
    process.diagnostics = record(process.node, DiagnosticArray, '/diagnostics')
    yield process
    process.close()


@pytest.fixture
def sim(world):
    """Stop the simulation: the scene as loaded, paused, at time 0."""
    state = SimulationState(state=SimulationState.STATE_STOPPED)
    world.call('set_simulation_state', state=state)
    assert world.call('reset_simulation').result.result == OK
    assert list(world.call('get_entities').entities) == ['anchor']
    return world


def spawn(sim, name='', resource='', uri='', renaming=False, position=(0.0, 0.0, 0.0),
          orientation=(0.0, 0.0, 0.0, 1.0)):
    pose = PoseStamped()
    p, q = pose.pose.position, pose.pose.orientation
    p.x, p.y, p.z = position
    q.x, q.y, q.z, q.w = orientation
    answer = sim.call('spawn_entity', name=name, resource_string=resource, uri=uri,
                      allow_renaming=renaming, initial_pose=pose)
    return answer.result.result, answer.result.error_message, answer.entity_name


def state_of(sim, entity):
    """(origin, orientation, velocity, angular velocity) of ``entity``'s frame, world."""
    answer = sim.call('get_entity_state', entity=entity)
    assert answer.result.result == OK, answer.result.error_message
    s = answer.state
    p, q, v, w = s.pose.position, s.pose.orientation, s.twist.linear, s.twist.angular
    return (np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w]),
            np.array([v.x, v.y, v.z]), np.array([w.x, w.y, w.z]))


def set_twist(sim, entity, linear, angular):
    """Give ``entity`` a twist, its pose kept."""
    origin, orientation, _, _ = state_of(sim, entity)
    request = sim.clients['set_entity_state'].srv_type.Request(entity=entity)
    s = request.state
    s.pose.position.x, s.pose.position.y, s.pose.position.z = origin
    q = s.pose.orientation
    q.x, q.y, q.z, q.w = orientation
    s.twist.linear.x, s.twist.linear.y, s.twist.linear.z = linear
    s.twist.angular.x, s.twist.angular.y, s.twist.angular.z = angular
    assert sim.call('set_entity_state', entity=entity, state=s).result.result == OK


def assert_moves_as_the_reference(sim, entity, mass, inertia, com, omega_world, steps=50):
    """Spin ``entity`` at rest (its centre of mass still) and compare with DOP853.

    The centre of mass is at ``com`` in the body's frame (m): with it still, the frame's
    origin moves at w x (-R com). ``inertia`` is about the
    centre of mass, in the body's axes. The tolerance is far below what a wrong inertia
    (ixx and iyy swapped) or a centre of mass at the frame's origin would give.
    """
    origin, orientation, _, _ = state_of(sim, entity)
    turn = Rotation.from_quat(orientation)
    lever = turn.apply(com)
    set_twist(sim, entity, np.cross(lever, omega_world), omega_world)
    assert sim.call('step_simulation', steps=steps).result.result == OK
    x, _, q, w_body = reference_motion(
        mass, inertia, (origin + lever, np.zeros(3), orientation, turn.inv().apply(omega_world)),
        [0.0, steps * DT])
    end = Rotation.from_quat(q[-1])
    got_origin, got_orientation, _, got_angular = state_of(sim, entity)
    np.testing.assert_allclose(got_origin, x[-1] - end.apply(com), atol=1e-5)
    assert abs(got_orientation @ q[-1]) == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(got_angular, end.apply(w_body[-1]), atol=1e-5)


def set_parameter(sim, name, value):
    """Set a string or string-array parameter of the node; (successful, reason)."""
    client = sim.node.create_client(SetParameters, f'{sim.prefix}/set_parameters')
    assert client.wait_for_service(timeout_sec=TIMEOUT)
    message = ParameterMessage(name=name)
    if isinstance(value, list):
        message.value.type = ParameterType.PARAMETER_STRING_ARRAY
        message.value.string_array_value = value
    else:
        message.value.type = ParameterType.PARAMETER_STRING
        message.value.string_value = value
    future = client.call_async(SetParameters.Request(parameters=[message]))
    spin_until(sim.executor, future.done, TIMEOUT, 'set_parameters answered')
    result, = future.result().results
    return result.successful, result.reason


def said(sim):
    """Every text the node has put on /rosout and /diagnostics so far."""
    texts = [log.msg for log in sim.logs]
    for array in sim.diagnostics:
        for status in array.status:
            texts.append(status.message)
            texts.extend(f'{value.key}: {value.value}' for value in status.values)
    return texts


def test_files_outside_the_allowed_directories_are_refused_as_missing_ones_are(sim):
    """/etc/shadow, /proc/self/maps, ../ and a symbolic link out: one answer, nothing quoted.

    Whether a file exists outside the allowed directories is not told: an existing one
    and a missing one get the same words, with only their names differing.
    """
    outside = sim.outside
    missing = spawn(sim, 'x', uri=str(outside / 'missing.yaml'))
    assert missing[0] == CODES.MISSING_ASSETS
    words = missing[1].replace(str(outside / 'missing.yaml'), '<name>')
    for uri in (str(outside / 'secret.yaml'), f'file://{outside}/secret.yaml', '/etc/shadow',
                '/proc/self/maps', f'../{outside.name}/secret.yaml', 'leak.yaml'):
        code, message, _ = spawn(sim, 'x', uri=uri)
        assert code == CODES.MISSING_ASSETS, message
        named = uri[len('file://'):] if uri.startswith('file://') else uri
        assert message.replace(named, '<name>') == words
    refused, reason = set_parameter(sim, 'scene', str(outside / 'secret.yaml'))
    assert not refused and 'not found in the allowed resource directories' in reason
    assert not any(SECRET in text for text in said(sim) + [reason])


def test_a_file_in_an_allowed_directory_is_refused_by_where_never_by_what_it_holds(sim):
    """A scene file holding a secret as a text, as a value and past a syntax error.

    The answers, the log lines and /diagnostics name the key path or line and column, and
    what kind of value is there; the scene parameter set to the first is loaded beside,
    refused, and logged the same way.
    """
    folder = sim.folder
    files = {'text.yaml': f'{SECRET}\n',
             'value.yaml': f'bodies:\n  - {{name: a, mass: {SECRET}, shape: {{type: sphere, '
                           'radius: 0.1}}\n',
             'syntax.yaml': f'bodies: [{{name: "{SECRET}\n',
             'tag.yaml': f'bodies: !{SECRET} []\n'}
    for name, text in files.items():
        (folder / name).write_text(text)
        code, message, _ = spawn(sim, uri=name)
        assert code == CODES.RESOURCE_PARSE_ERROR and SECRET not in message, message
        assert 'line' in message or 'bodies[0].mass' in message or '(document)' in message
    assert set_parameter(sim, 'scene', 'text.yaml')[0]   # accepted, then loaded and refused
    sim.until(lambda: any('refused' in log.msg and 'text.yaml' in log.msg
                          for log in sim.logs), 'the refusal logged')
    sim.until(lambda: any('text.yaml' in text for text in said(sim) if 'refus' in text),
              'the refusal on /rosout and /diagnostics')
    assert not any(SECRET in text for text in said(sim))


def test_meshes_are_read_from_the_allowed_directories_only(sim):
    """The same cube: beside the node, spawned; outside, refused as missing; by ../, too."""
    body = '{{shape: {{type: mesh, file: {}}}, mass: 1.0}}'
    assert spawn(sim, 'inside', body.format('cube.obj'))[0] == OK
    missing = spawn(sim, 'out', body.format(str(sim.outside / 'nothing.obj')))
    assert missing[0] == CODES.MISSING_ASSETS
    for file in (str(sim.outside / 'cube.obj'), f'../{sim.outside.name}/cube.obj'):
        code, message, _ = spawn(sim, 'out', body.format(file))
        assert (code, message) == missing[:2]
    (sim.folder / 'uses_outside.yaml').write_text(
        f'bodies:\n  - {{name: m, mass: 1.0, shape: {{type: mesh, file: '
        f'../{sim.outside.name}/cube.obj}}}}\n')
    assert spawn(sim, uri='uses_outside.yaml')[0] == CODES.MISSING_ASSETS
    assert list(sim.call('get_entities').entities) == ['anchor', 'inside']


def test_resource_paths_is_the_operators_and_no_client_widens_it(sim):
    """Read at start only: a client setting it is refused, the default stays; no file sets it."""
    client = sim.node.create_client(GetParameters, f'{sim.prefix}/get_parameters')
    assert client.wait_for_service(timeout_sec=TIMEOUT)
    future = client.call_async(GetParameters.Request(names=['resource_paths']))
    spin_until(sim.executor, future.done, TIMEOUT, 'get_parameters answered')
    value, = future.result().values
    assert list(value.string_array_value) == ['.', str(sim.folder)]
    assert not set_parameter(sim, 'resource_paths', ['/'])[0]
    assert spawn(sim, 'x', uri='/etc/passwd')[0] == CODES.MISSING_ASSETS
    (sim.folder / 'widening.yaml').write_text(
        f"limits: {{resource_paths: ['/']}}\nbodies:\n  - {{name: m, mass: 1.0, shape: "
        f"{{type: mesh, file: {sim.outside / 'cube.obj'}}}}}\n")
    code, message, _ = spawn(sim, uri='widening.yaml')   # a file never lifts its own limits
    assert code == CODES.RESOURCE_PARSE_ERROR and 'limits.resource_paths' in message


def test_spawn_formats_are_what_spawn_entity_reads(sim):
    formats = sim.call('get_simulator_features').features.spawn_formats
    assert sorted(formats) == ['rigid_sim_yaml', 'sdf', 'urdf']


def test_a_urdf_link_moves_as_its_inertial_says(sim):
    """Mass, centre of mass 0.1 m up z, the inertia turned 90 degrees about z, in the link."""
    start = (0.0, 0.0, 1.0)
    code, message, name = spawn(sim, resource=URDF, position=start)
    assert (code, name) == (OK, 'can'), message
    np.testing.assert_allclose(state_of(sim, 'can')[0], start, atol=1e-12)
    assert_moves_as_the_reference(sim, 'can', URDF_MASS, URDF_INERTIA, URDF_COM,
                                  np.array([1.0, 0.0, 1.0]))


def test_an_sdf_model_is_placed_by_its_poses_and_moves_as_its_inertial_says(sim):
    """The model at (1, 2, 3) turned 90 degrees about z: the link's (0.5, 0, 0) is (1, 2.5, 3)."""
    code, message, name = spawn(sim, resource=SDF)
    assert (code, name) == (OK, 'brick'), message
    origin, orientation, _, _ = state_of(sim, 'brick')
    np.testing.assert_allclose(origin, [1.0, 2.5, 3.0], atol=1e-12)
    half = math.sqrt(0.5)
    assert abs(orientation @ [0.0, 0.0, half, half]) == pytest.approx(1.0, abs=1e-12)
    assert_moves_as_the_reference(sim, 'brick', BRICK_MASS, np.diag(BRICK_INERTIA),
                                  np.zeros(3), np.array([0.5, 1.0, 2.0]))


def test_urdf_and_sdf_files_by_path_package_and_model_uris(sim):
    """package://p/x is <allowed dir>/p/x without an ament index, model://m its model.sdf."""
    folder = sim.folder
    (folder / 'my_robot' / 'urdf').mkdir(parents=True)
    (folder / 'my_robot' / 'meshes').mkdir()
    (folder / 'my_robot' / 'meshes' / 'cube.obj').write_text(CUBE_OBJ)
    meshed = URDF.replace('<cylinder radius="0.1" length="0.4"/>',
                          '<mesh filename="package://my_robot/meshes/cube.obj" scale="0.2 0.2 '
                          '0.2"/>')
    (folder / 'my_robot' / 'urdf' / 'can.urdf').write_text(meshed)
    (folder / 'brick').mkdir()
    (folder / 'brick' / 'model.sdf').write_text(SDF)
    (folder / 'model.sdf').write_text(SDF.replace('"brick"', '"slab"'))
    code, message, name = spawn(sim, uri='package://my_robot/urdf/can.urdf')
    assert (code, name) == (OK, 'can'), message
    assert spawn(sim, uri='model://brick')[:3:2] == (OK, 'brick')
    assert spawn(sim, uri=str(folder / 'model.sdf'))[:3:2] == (OK, 'slab')
    assert_moves_as_the_reference(sim, 'can', URDF_MASS, URDF_INERTIA, URDF_COM,
                                  np.array([1.0, 0.0, 1.0]))
    assert spawn(sim, uri='package://no_such_package/x.urdf')[0] == CODES.MISSING_ASSETS
    assert spawn(sim, uri='model://nothing')[0] == CODES.MISSING_ASSETS


@pytest.mark.parametrize('resource, code, words', [
    (TWO_LINKS, CODES.RESOURCE_PARSE_ERROR, '2 links'),
    (URDF.replace('<inertial>', '<!--').replace('</inertial>', '-->'),
     CODES.RESOURCE_PARSE_ERROR, 'no <inertial>'),
    ('<mujoco model="m"/>', CODES.UNSUPPORTED_FORMAT, 'mjcf is not served'),
    ('<sdf version="1.9"><world name="w"/></sdf>', CODES.UNSUPPORTED_FORMAT, 'world'),
    (SDF.replace('<box><size>0.1 0.2 0.3</size></box>', '<capsule/>'),
     CODES.UNSUPPORTED_FORMAT, 'geometry <capsule>'),
    ('<!DOCTYPE r [<!ENTITY e SYSTEM "file:///etc/passwd">]><robot name="&e;"/>',
     CODES.RESOURCE_PARSE_ERROR, 'line 1'),
], ids=['two-links', 'no-inertial', 'mjcf', 'sdf-world', 'capsule', 'external-entity'])
def test_models_not_served_are_refused_with_the_standards_code(sim, resource, code, words):
    got, message, _ = spawn(sim, 'm', resource)
    assert (got, words in message) == (code, True), message


def test_a_resource_string_above_the_scene_size_limit_is_refused_unparsed(sim):
    """A 16 MiB XML text is as much work as a 16 MiB scene: the same limit holds it.

    Parsing 40 MB of URDF took 11 s and 1.4 GB of memory in the node; above
    max_scene_bytes (16 MiB by default) the text is refused before any parser reads it.
    """
    padded = '<robot name="r">' + ' ' * (16 << 20) + '</robot>'
    got, message, _ = spawn(sim, 'big', padded)
    assert got == CODES.RESOURCE_PARSE_ERROR
    assert f'{len(padded)} characters, above the limit of {16 << 20} bytes' in message


def test_uris_of_formats_and_schemes_not_served_are_unsupported_formats(sim):
    (sim.folder / 'arm.xacro').write_text(URDF)
    for uri in ('arm.xacro', 'https://example.com/model.urdf'):
        assert spawn(sim, 'x', uri=uri)[0] == CODES.UNSUPPORTED_FORMAT


def test_names_are_the_requests_the_resources_or_generated(sim):
    """Without any name: NAME_INVALID, or with allow_renaming body, body_1, as the .srv says."""
    ball = '{shape: {type: sphere, radius: 0.1}, mass: 1.0}'
    assert spawn(sim, resource=ball)[0] == CODES.NAME_INVALID
    assert spawn(sim, resource=ball, renaming=True)[::2] == (OK, 'body')
    assert spawn(sim, resource=ball, renaming=True)[::2] == (OK, 'body_1')
    assert spawn(sim, resource=URDF, renaming=True)[::2] == (OK, 'can')
    assert spawn(sim, resource=URDF, renaming=True)[::2] == (OK, 'can_1')
    assert spawn(sim, 'tin', URDF)[::2] == (OK, 'tin')
    assert spawn(sim, resource=URDF)[0] == CODES.NAME_NOT_UNIQUE


def test_a_uri_spawns_one_entity_and_drops_none_of_its_effects_in_silence(sim):
    """Two bodies: refused, naming the count; a file's gravity: refused, naming it."""
    folder = sim.folder
    (folder / 'pair.yaml').write_text(
        'bodies:\n  - {name: a, shape: {type: sphere, radius: 0.1}, mass: 1.0}\n'
        '  - {name: b, shape: {type: sphere, radius: 0.1}, mass: 1.0}\n')
    code, message, name = spawn(sim, uri='pair.yaml')
    assert (code, name) == (CODES.RESOURCE_PARSE_ERROR, '') and '2 bodies' in message
    (folder / 'falling.yaml').write_text(
        'effects: {gravity: {acceleration: [0.0, 0.0, -9.81]}}\n'
        'bodies:\n  - {name: a, shape: {type: sphere, radius: 0.1}, mass: 1.0}\n')
    code, message, _ = spawn(sim, uri='falling.yaml')
    assert code == CODES.RESOURCE_PARSE_ERROR and "['gravity']" in message
    assert list(sim.call('get_entities').entities) == ['anchor']


def test_a_renamed_name_is_held_to_the_name_limit_as_any_name_is(sim):
    """A body name is at most 100 characters (it becomes topic and frame names).

    Renaming a taken 100-character name gives ``<name>_1``, 102 characters: refused as an
    invalid name, whether the body comes from a uri file or a resource_string.
    """
    longest = 'n' * 100
    body = '{name: %s, shape: {type: sphere, radius: 0.1}, mass: 1.0}' % longest
    (sim.folder / 'long.yaml').write_text(f'bodies:\n  - {body}\n')
    assert spawn(sim, uri='long.yaml', renaming=True)[::2] == (OK, longest)
    for request in ({'uri': 'long.yaml'}, {'resource': body}):
        code, message, name = spawn(sim, renaming=True, **request)
        assert (code, name) == (CODES.NAME_INVALID, ''), message
        assert 'at most 100' in message
    assert list(sim.call('get_entities').entities) == ['anchor', longest]
