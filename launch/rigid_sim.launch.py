# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Start the rigid_sim node and, if asked, RViz on its packaged view.

    ros2 launch rigid_sim rigid_sim.launch.py scene:=wrenches.yaml rate:=200 rviz:=true

An argument left empty is not passed on, so the node keeps its own default for it.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

ARGUMENTS = {
    'scene': ('', 'scene YAML file; a bare name is looked up among the packaged scenes '
                  '(empty: the default scene)'),
    'integrator': ('', 'integration method (empty: the node default)'),
    'rate': ('', 'ticks per second of wall time, Hz; 0: as fast as possible '
                 '(empty: the node default)'),
    'rviz': ('false', 'also start RViz with rviz/rigid_sim.rviz'),
}
NUMBERS = ('rate',)   # passed as doubles: the node refuses a text for a number


def simulator(context):
    """Describe the node, with the non-empty launch arguments as its parameters."""
    parameters = {}
    for name in ('scene', 'integrator', 'rate'):
        value = LaunchConfiguration(name).perform(context)
        if value:
            parameters[name] = float(value) if name in NUMBERS else value
    return [Node(package='rigid_sim', executable='rigid_sim_node', name='rigid_sim',
                 output='screen', parameters=[parameters])]


def generate_launch_description():
    """Arguments, the simulator, and RViz when ``rviz:=true`` (on simulated time)."""
    view = PathJoinSubstitution([FindPackageShare('rigid_sim'), 'rviz', 'rigid_sim.rviz'])
    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=default, description=description)
          for name, (default, description) in ARGUMENTS.items()),
        OpaqueFunction(function=simulator),
        Node(package='rviz2', executable='rviz2', arguments=['-d', view],
             parameters=[{'use_sim_time': True}], output='screen',
             condition=IfCondition(LaunchConfiguration('rviz'))),
    ])
