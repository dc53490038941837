# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Isolation for the tests that speak ROS.

Every run gets its own ROS_DOMAIN_ID (from the pid, unless the user set one: then that
one, so that runs the user keeps apart stay apart; each pytest-xdist worker the next ones,
:func:`own_domain`), discovery limited to this machine
(docs/ros_notes.md: unset, DDS multicasts out of the network interface) and a temporary log
directory, set here before any test starts rclpy or a node process. In-process tests narrow
discovery further, to OFF. The node is driven through the public test kit (the
``rigid_sim`` fixture of rigid_sim.testing); ``ros_tools.py`` builds the messages a test's
own node sends and reads what it heard. Every process a test starts goes through
``processes.py`` and is ended, with all it forked, when the test ends, however it ended.
"""
import importlib.util
import os
import shutil
import tempfile

import pytest

from domains import own_domain
import processes

ROS_LOG_DIR = tempfile.mkdtemp(prefix='rigid_sim_test_logs_')
os.environ['ROS_DOMAIN_ID'] = str(own_domain(os.environ, os.getpid()))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # subprocess tests need localhost
os.environ.pop('ROS_LOCALHOST_ONLY', None)  # deprecated, and it overrides the range
os.environ.pop('ROS_STATIC_PEERS', None)
os.environ['ROS_LOG_DIR'] = ROS_LOG_DIR
os.environ['RCUTILS_LOGGING_BUFFERED_STREAM'] = '0'  # a node process's lines arrive at once


def pytest_configure(config):
    """Refuse to start without the generated simulation_interfaces and tf2_msgs types.

    The tests use the real types, never stand-ins; on the pip route they come from
    ``rigid_sim_build_interfaces``, which the README's test command runs.
    """
    missing = [name for name in ('simulation_interfaces', 'tf2_msgs')
               if importlib.util.find_spec(name) is None]
    if missing:
        raise pytest.UsageError(f'{" and ".join(missing)} not installed: run '
                                '.venv/bin/rigid_sim_build_interfaces (README, test command)')


def pytest_sessionfinish(session, exitstatus):
    processes.end_since(0)
    shutil.rmtree(ROS_LOG_DIR, ignore_errors=True)


@pytest.fixture(autouse=True)
def end_started_processes():
    """End, with all they forked, the processes a test started, whatever became of it."""
    mark = processes.started()
    yield
    processes.end_since(mark)


@pytest.fixture
def ros_context(monkeypatch):
    """Yield a fresh rclpy context with discovery OFF: only nodes of this process meet."""
    import rclpy
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'OFF')
    context = rclpy.Context()
    rclpy.init(context=context)
    yield context
    rclpy.try_shutdown(context=context)


@pytest.fixture
def write_scene(tmp_path):
    """Write YAML text to a scene file in the test's directory and return its path."""
    def write(text, name='scene.yaml'):
        path = tmp_path / name
        path.write_text(text)
        return str(path)
    return write


@pytest.fixture
def every_shape_kind(monkeypatch):
    """Compile the contact stage for every shape kind, whatever the scene's are.

    Each set of kinds is a stage of its own, compiled cold in ~20 s of CPU, and the contact
    tests' scenes make a dozen sets: one stage serves them all. It differs from a scene's
    own only in branches that scene never takes; ``test_compile_work.py`` checks that a
    scene compiles its own set alone, and ``test_contact.py`` that the two step alike.
    """
    from rigid_sim.core import contact
    from rigid_sim.core.contact.narrow import BOX, CAPSULE, CYLINDER, SPHERE
    every = contact.ShapeKinds((SPHERE, BOX, CAPSULE, CYLINDER))
    monkeypatch.setattr(contact, 'ShapeKinds', lambda kinds: every)
