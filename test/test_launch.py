# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The launch file and the RViz view: they compile, load, and name what the node has.

``launch`` and ``launch_ros`` have no wheel here: the launch file runs on stand-ins for
their classes, which record what they were made with, and what it hands the node (its
namespace, parameters file and parameters) is then given to a real node.
"""
import ast
import importlib.util
import py_compile
import sys
import types
from pathlib import Path

import pytest
import yaml
from rclpy.parameter import Parameter

from rigid_sim.node import RigidSimNode
from rigid_sim.parameters import SPECS

ROOT = Path(__file__).resolve().parents[1]
LAUNCH = ROOT / 'launch' / 'rigid_sim.launch.py'
RVIZ = ROOT / 'rviz' / 'rigid_sim.rviz'


def test_launch_file_compiles_and_its_arguments_are_node_parameters_or_rviz(tmp_path):
    py_compile.compile(str(LAUNCH), cfile=str(tmp_path / 'launch.pyc'), doraise=True)
    tree = ast.parse(LAUNCH.read_text())
    arguments, = [ast.literal_eval(node.value) for node in tree.body
                  if isinstance(node, ast.Assign) and node.targets[0].id == 'ARGUMENTS']
    assert set(arguments) == {'scene', 'integrator', 'rate', 'start_paused', 'params_file',
                              'namespace', 'rviz', 'goal_body'}
    assert set(arguments) - {'rviz', 'params_file', 'namespace', 'goal_body'} <= set(SPECS)
    assert SPECS['rate'].kind is float   # the launch file passes rate as a double
    assert SPECS['start_paused'].kind is bool   # and start_paused as a bool


class Made:
    """Stands in for a launch class: keeps what it was made with."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


class Configuration(Made):
    """LaunchConfiguration: its value is the context's entry for its name."""

    def perform(self, context):
        return context[self.args[0]]


@pytest.fixture
def launch_file(monkeypatch):
    """Load the launch file with stand-ins for launch and launch_ros."""
    names = {'launch': ['LaunchDescription'],
             'launch.actions': ['DeclareLaunchArgument', 'OpaqueFunction'],
             'launch.conditions': ['IfCondition'],
             'launch.substitutions': ['LaunchConfiguration', 'PathJoinSubstitution'],
             'launch_ros.actions': ['Node'], 'launch_ros.substitutions': ['FindPackageShare']}
    for module_name, classes in names.items():
        module = types.ModuleType(module_name)
        for name in classes:
            setattr(module, name, Configuration if name == 'LaunchConfiguration'
                    else type(name, (Made,), {}))
        monkeypatch.setitem(sys.modules, module_name, module)
    spec = importlib.util.spec_from_file_location('rigid_sim_launch', LAUNCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def arguments(**given):
    """Return the launch context: every argument at its default, but those ``given``."""
    tree = ast.parse(LAUNCH.read_text())
    declared, = [ast.literal_eval(node.value) for node in tree.body
                 if isinstance(node, ast.Assign) and node.targets[0].id == 'ARGUMENTS']
    return {name: given.get(name, default) for name, (default, _) in declared.items()}


def test_launch_arguments_reach_the_node_namespace_parameters_file_and_start_paused(
        launch_file, ros_context, tmp_path):
    """params_file, namespace and start_paused, handed on as ros2 launch would, start the node.

    The file sets step_ticks and rate; the rate argument overrides the file's; the node runs
    under /sim1/rigid_sim, paused.
    """
    params = tmp_path / 'params.yaml'
    params.write_text(yaml.safe_dump({'/**': {'ros__parameters': {
        'step_ticks': 7, 'rate': 50.0}}}))
    simulator, viewer = launch_file.simulator(arguments(
        params_file=str(params), namespace='sim1', start_paused='True', rate='200'))
    made = simulator.kwargs
    assert made['namespace'] == 'sim1'
    files, given = made['parameters'][:-1], made['parameters'][-1]
    assert files == [str(params)] and given == {'start_paused': True, 'rate': 200.0}
    node = RigidSimNode(context=ros_context, namespace=made['namespace'],
                        cli_args=['--ros-args', '--params-file', *files],
                        parameter_overrides=[Parameter(k, value=v) for k, v in given.items()])
    try:
        assert node.get_fully_qualified_name() == '/sim1/rigid_sim'
        assert (node.paused, node.settings.step_ticks, node.settings.rate) == (True, 7, 200.0)
        published = {publisher.topic_name for publisher in node.publishers}
        remapped = {new for _, new in viewer.kwargs['remappings']}
        # No scene argument: the default scene, whose first body is the handle.
        goal = {'/sim1/rigid_sim/handle/goal_path', '/sim1/rigid_sim/handle/goal'}
        assert goal <= remapped and remapped - goal <= published
        assert '/sim1/rigid_sim/handle/goal' in node.goals.topics()
    finally:
        node.destroy_node()


def test_empty_launch_arguments_leave_the_node_its_defaults(launch_file):
    simulator, viewer = launch_file.simulator(arguments())
    assert simulator.kwargs['namespace'] == '' and simulator.kwargs['parameters'] == [{}]
    moved = {old: new for old, new in viewer.kwargs['remappings'] if old != new}
    assert moved == {'/rigid_sim/goal_body/goal': '/rigid_sim/handle/goal',
                     '/rigid_sim/goal_body/goal_path': '/rigid_sim/handle/goal_path'}


@pytest.mark.parametrize('given, body', [({'scene': 'springs.yaml'}, None),
                                         ({'scene': 'wrenches.yaml'}, 'cart'),
                                         ({'scene': 'wrenches.yaml', 'goal_body': 'puck'},
                                          'puck')])
def test_the_goal_tool_drives_a_body_of_the_launched_scene(launch_file, given, body):
    """By default the scene's first body (read here from the file), or the one named."""
    if body is None:
        scene = yaml.safe_load((ROOT / 'config' / 'scenes' / given['scene']).read_text())
        body = scene['bodies'][0]['name']
    _, viewer = launch_file.simulator(arguments(**given))
    remapped = dict(viewer.kwargs['remappings'])
    assert remapped['/rigid_sim/goal_body/goal'] == f'/rigid_sim/{body}/goal'
    assert remapped['/rigid_sim/goal_body/goal_path'] == f'/rigid_sim/{body}/goal_path'


def test_a_start_paused_that_is_not_a_bool_is_refused_naming_it(launch_file):
    with pytest.raises(ValueError, match="start_paused: expected true or false, got 'yes'"):
        launch_file.simulator(arguments(start_paused='yes'))


def displays():
    return yaml.safe_load(RVIZ.read_text())['Visualization Manager']


def test_rviz_view_has_world_fixed_frame_and_the_three_displays():
    view = displays()
    assert view['Global Options']['Fixed Frame'] == 'world'
    classes = {display['Class'] for display in view['Displays']}
    assert {'rviz_default_plugins/MarkerArray', 'rviz_default_plugins/PoseArray',
            'rviz_default_plugins/TF'} <= classes


def test_every_topic_the_rviz_view_names_is_published_by_the_node(rigid_sim, launch_file):
    """Topics are read from every display and tool of the file; wrenches.yaml runs.

    They are the ones the launch file remaps into a namespace, goal_body to the body the
    goal tool drives (wrenches.yaml's first, the cart). A body's goal path is published from
    its first goal on, and its goal is subscribed to once a publisher (RViz's goal tool)
    appears.
    """
    view = displays()
    topics = {item['Topic']['Value'] for item in view['Displays'] + view['Tools']
              if 'Topic' in item}
    assert topics == {f'/rigid_sim/{topic}' for topic in launch_file.VIEWED}
    node = rigid_sim(scene='wrenches.yaml').node
    published = {publisher.topic_name for publisher in node.publishers}
    goal = {'/rigid_sim/goal_body/goal_path', '/rigid_sim/goal_body/goal'}
    assert topics - goal <= published
    _, viewer = launch_file.simulator(arguments(scene='wrenches.yaml'))
    remapped = dict(viewer.kwargs['remappings'])
    assert remapped['/rigid_sim/goal_body/goal'] in node.goals.topics()
