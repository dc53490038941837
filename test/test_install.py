# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Packaging: a colcon install, the README's test command, bare scene names.

A colcon build gives the layout ``ros2 run`` and the ament index expect, and the installed
executable starts; the README's test command is the one CI runs; bare scene names are found where
the README says.
"""
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from ament_index_python.packages import get_package_share_directory

import processes

ROOT = Path(__file__).resolve().parents[1]
START_TIMEOUT = 600.0  # s: imports, a cold compile, discovery, on a loaded 2-core machine
BUILD_TIMEOUT = 120.0  # s; only a hung build comes near it, on a loaded machine too


def colcon_build(tmp_path):
    """``colcon build`` of this source tree into ``tmp_path``; the package's install prefix."""
    command = [sys.executable, '-m', 'colcon', '--log-base', str(tmp_path / 'log'), 'build',
               '--paths', str(ROOT), '--build-base', str(tmp_path / 'build'),
               '--install-base', str(tmp_path / 'install')]
    build = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True,
                           timeout=BUILD_TIMEOUT)
    assert build.returncode == 0, build.stdout + build.stderr
    return tmp_path / 'install' / 'rigid_sim'


def first_line_containing(process, words, timeout):
    """Read the process's output until a line contains ``words``; kill it after ``timeout``."""
    watchdog = threading.Timer(timeout, process.kill)
    watchdog.start()
    try:
        seen = []
        for line in process.stdout:
            seen.append(line)
            if words in line:
                return line
        raise AssertionError(f'{words!r} never printed; output: {"".join(seen)}')
    finally:
        watchdog.cancel()


def test_colcon_install_has_ament_layout_and_its_executable_starts(tmp_path, monkeypatch):
    """ros2 run looks in lib/<pkg>/, the ament index in share/ament_index and share/<pkg>.

    The installed executable finds the packaged default scene there by its bare name.
    """
    prefix = colcon_build(tmp_path)
    executable = prefix / 'lib' / 'rigid_sim' / 'rigid_sim_node'
    assert os.access(executable, os.X_OK)
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' /
            'rigid_sim').is_file()
    share = prefix / 'share' / 'rigid_sim'
    assert (share / 'package.xml').read_text() == (ROOT / 'package.xml').read_text()
    shipped = {path.relative_to(ROOT) for path in (ROOT / 'config').rglob('*') if path.is_file()}
    installed = {path.relative_to(share) for path in (share / 'config').rglob('*')
                 if path.is_file()}
    assert shipped and shipped == installed
    for folder, name in (('launch', 'rigid_sim.launch.py'), ('rviz', 'rigid_sim.rviz')):
        assert (share / folder / name).read_text() == (ROOT / folder / name).read_text()
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(prefix))
    assert Path(get_package_share_directory('rigid_sim')) == share

    site_packages, = prefix.glob('lib/python3*/site-packages')
    env = dict(os.environ, AMENT_PREFIX_PATH=str(prefix), PYTHONPATH=str(site_packages))
    process = processes.start([str(executable), '--ros-args', '-r', f'__ns:=/i{os.getpid()}'],
                              cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    try:
        started = first_line_containing(process, 'simulating', START_TIMEOUT)
        assert str(share / 'config' / 'scenes' / 'default.yaml') in started
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=START_TIMEOUT) == 0
    finally:
        processes.end(process)
        process.communicate()


def test_ci_runs_exactly_the_readme_test_command():
    """The command a newcomer copies from the README is the one CI proves works."""
    readme = (ROOT / 'README.md').read_text()
    ci_lines = (ROOT / '.ci' / 'run').read_text().splitlines()
    test_command = next(line for line in ci_lines if 'pytest' in line)
    assert test_command.strip() in readme.splitlines()
    # The suite speaks simulation_interfaces and tf2_msgs: the command builds them first.
    assert 0 < test_command.index('rigid_sim_build_interfaces') < test_command.index('pytest')


def test_readme_run_command_builds_the_standard_interfaces_before_the_node():
    """The run command serves simulation_interfaces: it builds the types, then starts the node.

    The build is its own step, before the node (never in its start); the README still gives
    the command that adds the types to a venv made without them.
    """
    readme = (ROOT / 'README.md').read_text().splitlines()
    run_command, = (line for line in readme if line.startswith('python3 -m venv')
                    and 'rigid_sim_node' in line)
    assert "'.[ros,interfaces]'" in run_command
    assert 0 < run_command.index('rigid_sim_build_interfaces') < run_command.index(
        'rigid_sim_node')
    add = ".venv/bin/pip install -e '.[interfaces]' && .venv/bin/rigid_sim_build_interfaces"
    assert add in readme


def test_readme_names_every_integrator_and_parameter():
    """Each name the node accepts for ``integrator``, and each parameter, is documented."""
    from rigid_sim.core.integrators import REGISTRY
    from rigid_sim.parameters import SPECS
    readme = (ROOT / 'README.md').read_text()
    for name in list(REGISTRY) + list(SPECS):
        assert f'`{name}`' in readme


def test_bare_scene_name_is_found_in_config_then_its_scenes(tmp_path, monkeypatch):
    """A bare scene name is looked up in the working directory, config/, then config/scenes/.

    That is the order the README gives; a miss names every allowed directory searched.
    """
    from rigid_sim import resources
    config = tmp_path / 'share' / 'config'
    (config / 'scenes').mkdir(parents=True)
    (config / 'mine.yaml').write_text('a')
    (config / 'scenes' / 'mine.yaml').write_text('b')
    (config / 'scenes' / 'shipped.yaml').write_text('c')
    monkeypatch.setattr(resources, 'config_directories', lambda: [config])
    monkeypatch.chdir(tmp_path)
    assert resources.find_scene('mine.yaml') == config / 'mine.yaml'
    assert resources.find_scene('shipped.yaml') == config / 'scenes' / 'shipped.yaml'
    (tmp_path / 'shipped.yaml').write_text('d')
    assert resources.find_scene('shipped.yaml') == tmp_path / 'shipped.yaml'
    with pytest.raises(FileNotFoundError) as refused:
        resources.find_scene('nowhere.yaml')
    for place in (tmp_path, config):
        assert repr(str(place)) in str(refused.value)
