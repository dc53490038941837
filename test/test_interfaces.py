# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The interface types built for the venv: the Jazzy releases' definitions and hashes.

Field names, types, constants and order are the protocol a client of another simulator
expects, and the RIHS01 type hash that DDS endpoints compare is computed from them. The
definitions in ``interfaces/`` are compared with the release files by git blob id (the
SHA-1 that ``git ls-tree`` lists for a tag), the built TFMessage's hash with the one Jazzy
installs report, and the venv's build with the definitions it was made from.
"""
import hashlib
import json
from pathlib import Path
import sys

from rigid_sim import interface_build

ROOT = Path(__file__).resolve().parents[1]
INTERFACES = ROOT / 'interfaces'
# `git ls-tree -r 1.5.1` of ros-simulation/simulation_interfaces (commit a3c60ff2715d, the
# head of its jazzy branch): the release Jazzy ships.
SIMULATION_INTERFACES_1_5_1 = {
    'LICENSE': '261eeb9e9f8b2b4b0d119366dda99c6fd7d35c64',
    'action/SimulateSteps.action': '4ba9ab72acb0e52e09b04326e88f3d77aeebb808',
    'msg/Bounds.msg': 'ed16b8924f460dabc48d5f836ae68f7361277cdd',
    'msg/EntityCategory.msg': '63d3c0f0f5706a099d6502912aba473c8a9742b8',
    'msg/EntityFilters.msg': '967ffacda704c3ed800f042bf75805f2ce0fe98b',
    'msg/EntityInfo.msg': 'eeb7fdc3a292edb449bc9e16d271788ec82496fa',
    'msg/EntityState.msg': 'c1a128dd617fdde50db2ed023df24c57b86fc4a0',
    'msg/NamedPose.msg': '54dec31be08843c7c99b79dc1634a3d6a895fb0b',
    'msg/Resource.msg': 'e16aeb2136de95b36c401b38cd698582f9a7b310',
    'msg/Result.msg': '64f3879daecb0eaeeab3b363b8e8bb6c3cb987e3',
    'msg/SimulationState.msg': '24246f7aae53829e307652f4ce1fccb0c0ae8c42',
    'msg/SimulatorFeatures.msg': '1073dee5931dd85e353939187f80bcdb527886f2',
    'msg/SpawnEntity.msg': '845e1e5578626697533ff666426f6cc5949fb60f',
    'msg/SpawnResult.msg': '5b79c962a591b54fa603f971fb8900d0f058a118',
    'msg/Spawnable.msg': 'd1f874d5478b51ec5c77e18a15b73514357b705b',
    'msg/TagsFilter.msg': '5d087f72fdd09775d300addf1ba496e0b5fd25db',
    'msg/WorldResource.msg': 'b10615e8e1c91e68f2377a2a55e76a7c3c29f1da',
    'package.xml': 'ca6b84efb9ab8115403e2cf00cffdf4cb7f4291b',
    'srv/DeleteEntity.srv': '334c92b7c66a1ea1938b1f153460d373d1f2beea',
    'srv/GetAvailableWorlds.srv': 'be520edff0752fab1e7e96679564173b42e0d11c',
    'srv/GetCurrentWorld.srv': '7ade9b39aac24c69617ffe2d52314b32d354e7d2',
    'srv/GetEntities.srv': '3cbf707a0d454b942e1b9eeff85987c8e525e485',
    'srv/GetEntitiesStates.srv': '1e18846fb3f4bf1881fd1bd06d9f27150274074c',
    'srv/GetEntityBounds.srv': '3c366402ffc81d094d1d3a0afbfb70957bf11ebf',
    'srv/GetEntityInfo.srv': '09370bc9b502d3d373ecfd1d10dcc8eeeb572ced',
    'srv/GetEntityState.srv': 'b054ec26440a62775d242d6f8521f491c5563293',
    'srv/GetNamedPoseBounds.srv': '088b9d3e47e40665aad2341d99c3c7005da39170',
    'srv/GetNamedPoses.srv': 'cb9158c42a6250740335509655469a996676521f',
    'srv/GetSimulationState.srv': '9b4cd2cdbc52ac4bbd2e372ed838fa923b041830',
    'srv/GetSimulatorFeatures.srv': '785efa84e2762a9c612e17108b9b201743fa09c3',
    'srv/GetSpawnables.srv': 'ad18d0f9d9d1e703755b2ee9d986c65c36439e83',
    'srv/LoadWorld.srv': 'c4736d4a31a3e682ff5efbe18f62ad674d57c2f3',
    'srv/ResetSimulation.srv': 'a53afd53dc65c42566227e7d7f7ce3cce61c10d7',
    'srv/SetEntityInfo.srv': 'd77561e4b7a6af1cc46360c8114295fa011acc06',
    'srv/SetEntityState.srv': '2e42e8b444090d29e7dd679340e0fdea0f1057bf',
    'srv/SetSimulationState.srv': 'e5a96044049b675d4e77972008883b95b98d7ba6',
    'srv/SpawnEntities.srv': '677b0a5dc67f2cd86c420007ceed41ae81417f0e',
    'srv/SpawnEntity.srv': 'de4696f754635e7af473f7621632504a21e20721',
    'srv/StepSimulation.srv': '6ec13766930f8accaee68db20391931379753d0f',
    'srv/UnloadWorld.srv': 'aa0475215397a45cfbc4ff28338bfc25bd81169a',
}
# `git ls-tree -r 0.36.4` of ros2/geometry2 (commit da10f77d98ab, Jazzy's release), tf2_msgs/
# and the repository's LICENSE.
TF2_MSGS_0_36_4 = {
    'LICENSE': 'd79557eefaf84816a7ce5f6201fa32fac60a69b5',
    'msg/TFMessage.msg': 'fda1e4d0985406667d26b7b36cbbedc9bb497074',
    'package.xml': '161e8833e4992002d52ec64012f2ae5120fba1fd',
}
# `ros2 topic info -v /tf` on Jazzy installs (the type hash of tf2_msgs/msg/TFMessage).
JAZZY_TF_MESSAGE_HASH = 'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'


def git_blob_id(path):
    """Return git's id of the file's bytes: SHA-1 of ``blob <size>``, a NUL, the bytes."""
    data = path.read_bytes()
    return hashlib.sha1(b'blob %d\0' % len(data) + data).hexdigest()


def definitions(package):
    """Relative path -> git blob id of every file of ``interfaces/<package>`` but ours."""
    folder = INTERFACES / package
    return {str(path.relative_to(folder)): git_blob_id(path)
            for path in sorted(folder.rglob('*'))
            if path.is_file() and path.name != 'CMakeLists.txt'}


def test_definitions_are_the_jazzy_release_files_byte_for_byte():
    assert definitions('simulation_interfaces') == SIMULATION_INTERFACES_1_5_1
    assert definitions('tf2_msgs') == TF2_MSGS_0_36_4


def test_the_release_fields_are_the_protocol_clients_use():
    """1.5.1 has SpawnEntity's uri and resource_string, and no set_pose flags (2.x differs)."""
    from simulation_interfaces.srv import SetEntityState, SpawnEntity
    assert list(SpawnEntity.Request.get_fields_and_field_types()) == [
        'name', 'allow_renaming', 'uri', 'resource_string', 'entity_namespace',
        'initial_pose']
    assert list(SetEntityState.Request.get_fields_and_field_types()) == ['entity', 'state']
    assert (SpawnEntity.Response.NAME_NOT_UNIQUE, SpawnEntity.Response.RESOURCE_PARSE_ERROR,
            SpawnEntity.Response.INVALID_POSE) == (101, 106, 109)


def test_built_tf_message_has_the_type_hash_of_a_jazzy_install():
    import tf2_msgs
    share = Path(sys.prefix) / 'share' / 'tf2_msgs' / 'msg' / 'TFMessage.json'
    described = json.loads(share.read_text())['type_hashes'][0]
    assert described == {'type_name': 'tf2_msgs/msg/TFMessage',
                         'hash_string': JAZZY_TF_MESSAGE_HASH}
    assert Path(sys.prefix).resolve() in Path(tf2_msgs.__file__).resolve().parents


def test_the_venv_holds_the_build_of_these_definitions():
    """Each package's stamp in the venv names the key of the current definitions."""
    for package in interface_build.PACKAGES:
        stamp = Path(sys.prefix) / 'share' / package / interface_build.STAMP
        key = interface_build.build_key(INTERFACES, package)
        assert stamp.read_text().strip() == key, f'{package}: run rigid_sim_build_interfaces'


def test_build_key_follows_every_byte_of_the_definitions(tmp_path):
    copy = tmp_path / 'interfaces'
    (copy / 'tf2_msgs' / 'msg').mkdir(parents=True)
    for name in ('msg/TFMessage.msg', 'package.xml'):
        (copy / 'tf2_msgs' / name).write_bytes((INTERFACES / 'tf2_msgs' / name).read_bytes())
    (copy / interface_build.PROJECT_INCLUDE).write_text('# fix\n')
    key = interface_build.build_key(copy, 'tf2_msgs')
    assert interface_build.build_key(copy, 'tf2_msgs') == key
    message = copy / 'tf2_msgs' / 'msg' / 'TFMessage.msg'
    message.write_bytes(message.read_bytes() + b' ')
    assert interface_build.build_key(copy, 'tf2_msgs') != key


def test_a_package_found_outside_the_prefix_is_left_to_its_install(tmp_path):
    """On a ROS install the package comes from /opt/ros/...: nothing is built."""
    assert interface_build.provided_elsewhere('tf2_msgs', sys.prefix) is None
    elsewhere = interface_build.provided_elsewhere('tf2_msgs', tmp_path)
    assert elsewhere is not None and elsewhere.name == 'tf2_msgs'
    assert 'rosidl_generator_py' in interface_build.missing_build_wheels(tmp_path)
    assert interface_build.missing_build_wheels(sys.prefix) == []


def test_node_without_simulation_interfaces_says_once_what_it_does_not_serve(
        ros_context, write_scene, capfd, monkeypatch):
    """Where the package is missing the node runs, serving none of it, and says how to add it."""
    import importlib.util
    from rigid_sim.node import RigidSimNode
    found = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, 'find_spec', lambda name, *rest: None
                        if name == 'simulation_interfaces' else found(name, *rest))
    scene = write_scene('bodies: [{name: box, shape: {type: sphere, radius: 0.1}, mass: 1.0}]')
    node = RigidSimNode(context=ros_context, cli_args=['--ros-args', '-p', f'scene:={scene}'])
    try:
        assert node.sim_interfaces is None
        assert not [name for name, _ in node.get_service_names_and_types_by_node(
            'rigid_sim', '/') if name.endswith('step_simulation')]
        said = capfd.readouterr().err
        assert said.count('simulation_interfaces is not installed') == 1
        assert '~/spawn_entity' in said and 'rigid_sim_build_interfaces' in said
    finally:
        node.destroy_node()
