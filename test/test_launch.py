# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The launch file and the RViz view: they compile, load, and name what the node has.

``launch`` has no wheel here, so the launch file is compiled and read, not run.
"""
import ast
import py_compile
from pathlib import Path

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
    assert set(arguments) == {'scene', 'integrator', 'rate', 'rviz'}
    assert set(arguments) - {'rviz'} <= set(SPECS)
    assert SPECS['rate'].kind is float   # the launch file passes rate as a double


def displays():
    return yaml.safe_load(RVIZ.read_text())['Visualization Manager']


def test_rviz_view_has_world_fixed_frame_and_the_three_displays():
    view = displays()
    assert view['Global Options']['Fixed Frame'] == 'world'
    classes = {display['Class'] for display in view['Displays']}
    assert {'rviz_default_plugins/MarkerArray', 'rviz_default_plugins/PoseArray',
            'rviz_default_plugins/TF'} <= classes


def test_every_topic_the_rviz_view_names_is_published_by_the_node(ros_context):
    """Topics are read from every display and tool of the file; wrenches.yaml runs.

    A body's goal path is published from its first goal on, and its goal is subscribed to
    once a publisher (RViz's goal tool) appears: both are the cart's.
    """
    view = displays()
    topics = {item['Topic']['Value'] for item in view['Displays'] + view['Tools']
              if 'Topic' in item}
    assert len(topics) == 4
    node = RigidSimNode(context=ros_context,
                        parameter_overrides=[Parameter('scene', value='wrenches.yaml')])
    published = {publisher.topic_name for publisher in node.publishers}
    goal_topics = node.goals.topics()
    node.destroy_node()
    assert topics - {'/rigid_sim/cart/goal_path', '/rigid_sim/cart/goal'} <= published
    assert '/rigid_sim/cart/goal' in goal_topics
