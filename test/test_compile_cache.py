# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""numba's cache is keyed on the core's sources, and a compile is told apart from a load.

A damaged or unusable cache never stops a process: the damaged entries are compiled and
cached again, an unusable directory caches nothing, each said once. numba's cache settings
are process-wide, so these run in child processes with a cache directory of their own.
"""
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
from types import SimpleNamespace

from numba import njit
from numba.core import event

import processes
import rigid_sim
from rigid_sim.core import compile_cache
from rigid_sim.core.warm_up import Compilations
from rigid_sim.node import warm_up as node_warm_up

PACKAGE = Path(rigid_sim.__file__).resolve().parent
# The children compile (or load) a small core kernel, check_substep, for a state of float32
# that nothing else uses: two kernels, it and the helper that reads a quaternion.
SMALL_KERNEL = 'kinematics.check_substep(np.ones((1, 13), np.float32))'
SMALL_KERNEL_FILES = ('kinematics.check_substep', 'kinematics.orientation')
# This one prints where numba's cache is and how many kernels it had to compile.
CHILD = f'''
import numpy as np
from numba.core import event
from rigid_sim.core import CACHE_DIRECTORY, kinematics
from rigid_sim.core.warm_up import Compilations
compilations = Compilations()
with event.install_listener('numba:compile', compilations):
    {SMALL_KERNEL}
print(CACHE_DIRECTORY, compilations.count)
'''


# This one prints how many it compiled, how many damaged entries it deleted and the note.
TWO_KERNELS = f'''
import numpy as np
from numba.core import event
from rigid_sim.core import compile_cache, kinematics
from rigid_sim.core.warm_up import Compilations
compilations = Compilations()
with event.install_listener('numba:compile', compilations):
    {SMALL_KERNEL}
print(compilations.count, compile_cache.STATE.healed, compile_cache.caching_note())
'''
EXECUTABLE = Path(sys.executable).with_name('rigid_sim_node')
EXIT_TIMEOUT = 120.0  # s: a liveness bound only


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

    With XDG_CACHE_HOME, then NUMBA_CACHE_DIR, set to empty directories: the kernel and its
    helper are compiled once and written under <root>/rigid_sim/numba/<key>, a second
    process loads them from there without compiling, and no cache file appears in the
    package tree.
    """
    in_package = cached_files(PACKAGE)
    key = compile_cache.source_key()
    base = {name: value for name, value in os.environ.items()
            if name not in ('NUMBA_CACHE_DIR', 'XDG_CACHE_HOME')}
    for variable in ('XDG_CACHE_HOME', 'NUMBA_CACHE_DIR'):
        root = tmp_path / variable
        environment = dict(base, **{variable: str(root)})
        expected = root / 'rigid_sim' / 'numba' / key
        assert run_child(environment) == (expected, 2)
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
                        lambda world, integrator, imus: _fresh_kernel(1.5))
    world = SimpleNamespace(effects=[], bodies=SimpleNamespace(count=1))
    assert node_warm_up(world, 'rk4', logger) == 1
    assert len(logger.lines) == 2
    assert logger.lines[0].startswith('compiling the rk4 kernels for 1 bodies with effects '
                                      '[none], not found in the kernel cache (')
    assert logger.lines[1].startswith('compiled 1 kernels in ')
    assert node_warm_up(world, 'rk4', logger) == 0
    assert len(logger.lines) == 2


def test_the_node_warms_up_the_readings_of_its_scene_imus(ros_context, monkeypatch):
    """A node on the IMU scene hands its IMU to the warm-up, which compiles its readings.

    Without them the first tick would compile the readings, unannounced.
    """
    from rclpy.parameter import Parameter
    from rigid_sim.node import RigidSimNode
    handed = []
    monkeypatch.setattr('rigid_sim.core.warm_up.warm_up',
                        lambda world, integrator, imus: handed.append(imus) or 0.0)
    node = RigidSimNode(context=ros_context,
                        parameter_overrides=[Parameter('scene', value='imu.yaml')])
    try:
        assert len(handed) == 1 and handed[0] is not None
        assert handed[0].bodies == node.imu_outputs.imus.bodies == [0]
    finally:
        node.destroy_node()


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


def run_two_kernels(environment):
    """Run ``TWO_KERNELS``: (compiled, healed, note) and its standard error."""
    done = subprocess.run([sys.executable, '-c', TWO_KERNELS], env=environment,
                          cwd=PACKAGE.parent, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    compiled, healed, note = done.stdout.strip().split(' ', 2)
    return (int(compiled), int(healed), note), done.stderr


def own_cache(tmp_path):
    """Return an environment whose kernel cache is new, under ``tmp_path``, and its directory."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / 'cache'))
    return environment, tmp_path / 'cache' / 'rigid_sim' / 'numba' / compile_cache.source_key()


def truncate(path):
    path.write_bytes(path.read_bytes()[:100])


def scribble(path):
    path.write_bytes(b'not a pickle\n' * 10)


def test_damaged_cache_files_are_warned_about_once_and_compiled_again(tmp_path):
    """Truncated code files, then garbage index files: each start warns once and rebuilds.

    numba raises UnpicklingError or EOFError loading them; the kernels are compiled again,
    cached again, and the next process loads them without compiling.
    """
    environment, directory = own_cache(tmp_path)
    cached = f'cached afterwards in {directory}'
    assert run_two_kernels(environment)[0] == (2, 0, cached)
    for damage, suffix in ((truncate, '.nbc'), (scribble, '.nbi')):
        damaged = [path for path in directory.rglob(f'*{suffix}')
                   if path.name.startswith(SMALL_KERNEL_FILES)]
        assert len(damaged) == 2
        for path in damaged:
            damage(path)
        counts, errors = run_two_kernels(environment)
        assert counts == (2, 2, cached), errors
        assert errors.count('damaged entries are deleted and compiled again') == 1, errors
        assert run_two_kernels(environment) == ((0, 0, cached), '')


def test_an_unusable_cache_directory_caches_nothing_and_says_so_once(tmp_path):
    """NUMBA_CACHE_DIR naming a regular file: kernels compile in memory, nothing is written.

    The warning names the directory and the reason; no temporary directory is made, and
    nothing lands in the package tree.
    """
    in_package = cached_files(PACKAGE)
    blocker = tmp_path / 'a_file'
    blocker.write_text('')
    temporary = tmp_path / 'tmp'
    temporary.mkdir()
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(blocker), TMPDIR=str(temporary))
    for _ in range(2):   # every process compiles again: nothing was cached
        (compiled, healed, note), errors = run_two_kernels(environment)
        assert (compiled, healed) == (2, 0)
        assert note.startswith(f'not cached: {blocker}/rigid_sim/numba/') and \
            note.endswith('cannot be used (Not a directory)')
        assert errors.count('the compiled kernels will not be cached') == 1, errors
    assert list(temporary.iterdir()) == [] and blocker.read_text() == ''
    assert cached_files(PACKAGE) == in_package


def test_a_node_stopped_while_compiling_without_a_cache_leaves_no_files(tmp_path):
    """Without a usable cache the node says it will not cache; SIGTERM leaves nothing behind.

    Its compile line says why the kernels are not cached; a SIGTERM as it compiles ends it
    with status 0 and nothing in its temporary directory.
    """
    blocker = tmp_path / 'a_file'
    blocker.write_text('')
    temporary = tmp_path / 'tmp'
    temporary.mkdir()
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(blocker), TMPDIR=str(temporary))
    node = processes.start([str(EXECUTABLE), '--ros-args', '-r',
                            f'__ns:=/cache{os.getpid()}'], env=environment,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        lines = []
        while not (lines and 'compiling' in lines[-1]):
            lines.append(node.stdout.readline())
            assert lines[-1], f'ended before compiling:\n{"".join(lines)}'
        node.send_signal(signal.SIGTERM)
        output = ''.join(lines) + node.communicate(timeout=EXIT_TIMEOUT)[0]
    finally:
        if node.poll() is None:
            processes.end(node)
    assert node.returncode == 0, output
    assert f'not cached: {blocker}/rigid_sim/numba/' in lines[-1]
    assert 'cannot be used (Not a directory)' in lines[-1], lines[-1]
    assert 'afterwards' not in output and 'next start' not in output
    assert output.count('the compiled kernels will not be cached') == 1, output
    assert list(temporary.iterdir()) == []
