# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
r"""Start the rigid_sim node and, if asked, RViz on its packaged view.

    ros2 launch rigid_sim rigid_sim.launch.py scene:=wrenches.yaml rate:=200 rviz:=true
    ros2 launch rigid_sim rigid_sim.launch.py rviz:=true goal_body:=box
    ros2 launch rigid_sim rigid_sim.launch.py params_file:=my.yaml namespace:=sim1 \
        start_paused:=true

An argument left empty is not passed on, so the node keeps its own default for it (or the
value of ``params_file``, which the other arguments override).
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
    'start_paused': ('', 'true: start with integration paused, advanced by ~/step '
                         '(empty: the node default, false)'),
    'params_file': ('', 'a parameters YAML file such as config/rigid_sim.yaml; the '
                        'arguments above override it (empty: none)'),
    'namespace': ('', 'namespace of the node: topics and services under '
                      '/<namespace>/rigid_sim/ (empty: none)'),
    'rviz': ('false', 'also start RViz with rviz/rigid_sim.rviz'),
    'goal_body': ('', 'the body RViz\'s "2D Goal Pose" tool sends goals to and whose goal '
                      'path it shows (empty: the first body of the scene argument\'s scene)'),
}
PARAMETERS = ('scene', 'integrator', 'rate', 'start_paused')   # passed as node parameters
NUMBERS = ('rate',)            # passed as doubles: the node refuses a text for a number
BOOLEANS = ('start_paused',)   # passed as bools, from true or false
# The topics rviz/rigid_sim.rviz names under /rigid_sim/; goal_body stands for the body
# the goal tool drives, which no name fits in every scene.
VIEWED = ('markers', 'poses', 'goal_body/goal_path', 'goal_body/goal')


def typed(name, value):
    """Return the launch argument ``value`` as the type parameter ``name`` has."""
    if name in NUMBERS:
        return float(value)
    if name in BOOLEANS:
        if value.lower() not in ('true', 'false'):
            raise ValueError(f'launch argument {name}: expected true or false, got {value!r}')
        return value.lower() == 'true'
    return value


def first_body(scene):
    """Name the first body of the launch argument ``scene`` (empty: the default scene).

    '' when the file cannot be read as a scene; the node says why when it loads it.
    """
    from rigid_sim.resources import DEFAULT_SCENE, find_scene
    import yaml
    try:
        return str(yaml.safe_load(find_scene(scene or DEFAULT_SCENE).read_text())
                   ['bodies'][0]['name'])
    except (OSError, yaml.YAMLError, KeyError, IndexError, TypeError):
        return ''


def simulator(context):
    """Make the node in its namespace, with the parameters file and the non-empty arguments."""
    def argument(name):
        return LaunchConfiguration(name).perform(context)
    parameters = {name: typed(name, argument(name)) for name in PARAMETERS if argument(name)}
    files = [argument('params_file')] if argument('params_file') else []
    namespace = argument('namespace')
    view = PathJoinSubstitution([FindPackageShare('rigid_sim'), 'rviz', 'rigid_sim.rviz'])
    # The view names /rigid_sim/<topic>; in a namespace the node publishes elsewhere.
    prefix = f'/{namespace.strip("/")}/rigid_sim' if namespace.strip('/') else '/rigid_sim'
    body = argument('goal_body') or first_body(argument('scene')) or 'goal_body'
    return [Node(package='rigid_sim', executable='rigid_sim_node', name='rigid_sim',
                 namespace=namespace, output='screen', parameters=[*files, parameters]),
            Node(package='rviz2', executable='rviz2', arguments=['-d', view],
                 parameters=[{'use_sim_time': True}], output='screen',
                 remappings=[(f'/rigid_sim/{topic}',
                              f'{prefix}/{topic.replace("goal_body/", body + "/")}')
                             for topic in VIEWED],
                 condition=IfCondition(LaunchConfiguration('rviz')))]


def generate_launch_description():
    """Arguments, the simulator, and RViz when ``rviz:=true`` (on simulated time)."""
    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=default, description=description)
          for name, (default, description) in ARGUMENTS.items()),
        OpaqueFunction(function=simulator),
    ])
