# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""numba's cache is keyed on the core's sources, and a compile is told apart from a load."""
import os
from pathlib import Path
import shutil
import subprocess
import sys
from types import SimpleNamespace

from numba import njit
from numba.core import event

import rigid_sim
from rigid_sim.core import compile_cache
from rigid_sim.core.warm_up import Compilations
from rigid_sim.node import warm_up as node_warm_up

PACKAGE = Path(rigid_sim.__file__).resolve().parent
# The child compiles one small core kernel for a signature nothing else uses and prints
# where numba's cache is and how many kernels it had to compile.
CHILD = '''
import numpy as np
from numba.core import event
from rigid_sim.core import CACHE_DIRECTORY, kinematics
from rigid_sim.core.warm_up import Compilations
compilations = Compilations()
with event.install_listener('numba:compile', compilations):
    kinematics.cross(np.ones(3, np.float32), np.ones(3, np.float32))
print(CACHE_DIRECTORY, compilations.count)
'''


def cached_files(root):
    """Every numba cache file (index or code) under ``root``."""
    return sorted(str(path) for path in Path(root).rglob('*.nb[ic]'))


def test_the_key_follows_every_byte_of_every_core_source(tmp_path):
    """A copy of the core has the package's key, and any change gives another.

    Editing one byte of a callee's file, adding a file or another numba version each give
    a new key.
    """
    core = tmp_path / 'core'
    shutil.copytree(PACKAGE / 'core', core, ignore=shutil.ignore_patterns('__pycache__'))
    key = compile_cache.source_key(core)
    assert key == compile_cache.source_key(PACKAGE / 'core')
    assert compile_cache.KEY.fullmatch(key)
    callee = core / 'kinematics.py'
    callee.write_bytes(callee.read_bytes().replace(b'return', b'return ', 1))
    edited = compile_cache.source_key(core)
    assert edited != key
    (core / 'effects' / 'new_effect.py').write_text('')
    assert compile_cache.source_key(core) not in (key, edited)
    assert compile_cache.source_key(core, '0.0.0') != compile_cache.source_key(core)


def test_the_cache_root_honours_numba_cache_dir_then_xdg_then_home():
    """The user's NUMBA_CACHE_DIR wins, then XDG_CACHE_HOME, then ~/.cache."""
    tail = Path('rigid_sim', 'numba')
    assert compile_cache.cache_root({'NUMBA_CACHE_DIR': '/n', 'XDG_CACHE_HOME': '/x'}) \
        == Path('/n') / tail
    assert compile_cache.cache_root({'XDG_CACHE_HOME': '/x'}) == Path('/x') / tail
    assert compile_cache.cache_root({}) == Path.home() / '.cache' / tail


def test_only_stale_keyed_directories_are_pruned(tmp_path):
    """Old keyed directories go; the current one, recent ones and other names stay."""
    keep, recent, stale = 'a' * 16, 'b' * 16, 'c' * 16
    for name in (keep, recent, stale, 'notes'):
        (tmp_path / name).mkdir()
    old = (tmp_path / stale).stat().st_mtime - compile_cache.STALE_AFTER - 1.0
    for name in (keep, stale, 'notes'):
        os.utime(tmp_path / name, (old, old))
    compile_cache.prune(tmp_path, keep)
    assert sorted(path.name for path in tmp_path.iterdir()) == sorted([keep, recent, 'notes'])


def run_child(environment):
    """Run ``CHILD`` with ``environment``; its cache directory and compile count."""
    done = subprocess.run([sys.executable, '-c', CHILD], env=environment, cwd=PACKAGE.parent,
                          capture_output=True, text=True, check=True)
    directory, count = done.stdout.split()
    return Path(directory), int(count)


def test_a_process_caches_under_the_keyed_directory_and_not_in_the_package(tmp_path):
    """A kernel compiled in a process is cached under the keyed directory only.

    With XDG_CACHE_HOME, then NUMBA_CACHE_DIR, set to empty directories: the kernel is
    compiled once and written under <root>/rigid_sim/numba/<key>, a second process loads it
    from there without compiling, and no cache file appears in the package tree.
    """
    in_package = cached_files(PACKAGE)
    key = compile_cache.source_key()
    base = {name: value for name, value in os.environ.items()
            if name not in ('NUMBA_CACHE_DIR', 'XDG_CACHE_HOME')}
    for variable in ('XDG_CACHE_HOME', 'NUMBA_CACHE_DIR'):
        root = tmp_path / variable
        environment = dict(base, **{variable: str(root)})
        expected = root / 'rigid_sim' / 'numba' / key
        assert run_child(environment) == (expected, 1)
        assert cached_files(expected) and cached_files(root) == cached_files(expected)
        assert run_child(environment) == (expected, 0)
    assert cached_files(PACKAGE) == in_package


@njit
def _fresh_kernel(x):
    """Add one: a kernel cached nowhere, so its first call with a type always compiles."""
    return x + 1


class RecordingLogger:
    """Collects the lines logged at info level."""

    def __init__(self):
        self.lines = []

    def info(self, line):
        """Record ``line``."""
        self.lines.append(line)


def test_compilations_are_counted_and_the_first_announced_before_it_runs():
    """A compilation counts once and is announced as it starts; a second call is free.

    Calling the kernel again with the same type compiles nothing.
    """
    calls = []
    compilations = Compilations(lambda: calls.append(compilations.count))
    with event.install_listener('numba:compile', compilations):
        assert _fresh_kernel(1j) == 1 + 1j
        assert _fresh_kernel(2j) == 1 + 2j
    assert compilations.count == 1 and calls == [1]


def test_the_node_logs_compiling_only_when_something_compiles(monkeypatch):
    """The node's warm-up logs before and after a compilation, and nothing without one."""
    logger = RecordingLogger()
    monkeypatch.setattr('rigid_sim.core.warm_up.warm_up',
                        lambda world, integrator: _fresh_kernel(1.5))
    world = SimpleNamespace(effects=[], bodies=SimpleNamespace(count=1))
    assert node_warm_up(world, 'rk4', logger) == 1
    assert len(logger.lines) == 2
    assert logger.lines[0].startswith('compiling the rk4 kernels for 1 bodies with effects '
                                      '[none]: not in the kernel cache ')
    assert logger.lines[1].startswith('compiled 1 kernels in ')
    assert node_warm_up(world, 'rk4', logger) == 0
    assert len(logger.lines) == 2


def test_a_second_node_for_the_same_scene_compiles_nothing(ros_context):
    """A second node for the same scene finds every kernel compiled.

    The node warms up at start; once one node has compiled or loaded the kernels, a second
    one in the process compiles none and so logs no compile line.
    """
    from rigid_sim.node import RigidSimNode
    first = RigidSimNode(context=ros_context)
    second = RigidSimNode(context=ros_context)
    try:
        assert first.compiled >= 0 and second.compiled == 0
    finally:
        first.destroy_node()
        second.destroy_node()
