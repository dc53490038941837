# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_build_interfaces``: simulation_interfaces and tf2_msgs for a venv without ROS.

No wheel on PyPI holds these two packages, and rclpy can use a message type only with its
compiled type support, so a venv gets them by building the definitions this repository keeps
in ``interfaces/`` (the Jazzy releases', byte for byte) with rosidl, as a ROS build farm
would, and installing the result into the venv's own prefix: the rclpy wheel already puts
``<venv>/lib`` on the library path, so nothing needs setting at run time.

A build is kept in a per-machine cache under a key made of the definitions' contents, the
Python ABI and the rclpy wheel's version; a second venv on the same machine copies it
in a second. A package that Python already finds outside the venv (a ROS install, where
rosdep brings both) is left alone. docs/ros_notes.md ("Building interface packages in a
venv") has the measurements behind each step.
"""
import argparse
import fcntl
import hashlib
from importlib import metadata
import importlib.util
import os
from pathlib import Path
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time

from rigid_sim.resources import packaged_directories

# Built in this order; neither depends on the other.
PACKAGES = ('tf2_msgs', 'simulation_interfaces')
# A type of each package whose type support a fresh interpreter must load after installing.
PROBES = {'tf2_msgs': 'tf2_msgs.msg.TFMessage',
          'simulation_interfaces': 'simulation_interfaces.srv.SpawnEntity'}
# Written into <prefix>/share/<package>/ with the key of what was installed there.
STAMP = 'rigid_sim_build_key'
# Makes the wheels' message targets use this Python's headers (see the file).
PROJECT_INCLUDE = 'wheel_include_dirs.cmake'
ADD_WHEELS = "pip install -e '.[interfaces]'"
# What the node logs where a package is missing: how to add it on either route.
HOW_TO_ADD = (f"add it to a venv with `{ADD_WHEELS} && rigid_sim_build_interfaces` from the "
              "clone, or on a ROS install with rosdep")


class BuildError(RuntimeError):
    """A step of the build failed; the message says which and where its log is."""


def definitions_root():
    """Return the packaged ``interfaces/`` folder (the source tree's or an installed copy)."""
    found = packaged_directories('interfaces')
    if not found:
        raise BuildError('no interfaces/ folder found beside the rigid_sim package or in '
                         'share/rigid_sim: reinstall rigid_sim')
    return found[0]


def build_key(root, package):
    """Hex digest of everything the build of ``package`` depends on, for the cache."""
    digest = hashlib.sha256()
    files = sorted(path for path in (root / package).rglob('*') if path.is_file())
    for path in files + [root / PROJECT_INCLUDE]:
        digest.update(str(path.relative_to(root)).encode() + b'\0' + path.read_bytes())
    digest.update(sysconfig.get_config_var('SOABI').encode())
    digest.update(metadata.version('ros-jazzy-rclpy').encode())
    return digest.hexdigest()[:24]


def cache_dir():
    """Per-machine cache of built packages (``$XDG_CACHE_HOME/rigid_sim/interfaces``)."""
    base = os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache'
    return Path(base) / 'rigid_sim' / 'interfaces'


def provided_elsewhere(package, prefix):
    """Where Python finds ``package`` outside ``prefix`` (a ROS install), else None."""
    spec = importlib.util.find_spec(package)
    if spec is None or spec.origin is None:
        return None
    origin = Path(spec.origin).resolve()
    return None if Path(prefix).resolve() in origin.parents else origin.parent


def build_environment(prefix):
    """Environment for CMake: the prefix's tools first, its packages found by ament."""
    env = dict(os.environ)
    env['PATH'] = os.pathsep.join([str(Path(prefix) / 'bin'), env.get('PATH', '')])
    env['AMENT_PREFIX_PATH'] = env['CMAKE_PREFIX_PATH'] = str(prefix)
    return env


def run_logged(command, log, env):
    """Run ``command``, appending its output to ``log``; raise BuildError if it fails."""
    with open(log, 'a') as out:
        out.write('$ ' + ' '.join(command) + '\n')
        out.flush()
        done = subprocess.run(command, stdout=out, stderr=subprocess.STDOUT, env=env)
    if done.returncode != 0:
        tail = ''.join(Path(log).read_text().splitlines(keepends=True)[-15:])
        raise BuildError(f'{command[0]} failed; full log in {log}; its end:\n{tail}')


def cmake_build(root, package, install_to, work, prefix):
    """Configure, build and install ``package`` into ``install_to``, logging in ``work``."""
    env = build_environment(prefix)
    cmake = shutil.which('cmake', path=env['PATH'])
    if cmake is None:
        raise BuildError(f'cmake not found: {ADD_WHEELS} installs it')
    generator = ['-G', 'Ninja'] if shutil.which('ninja', path=env['PATH']) else []
    build, log = work / 'build', work / 'build.log'
    run_logged([cmake, '-S', str(root / package), '-B', str(build), *generator,
                '-DBUILD_TESTING=OFF', '-DCMAKE_BUILD_TYPE=Release',
                f'-DPython3_EXECUTABLE={sys.executable}',
                f'-DCMAKE_INSTALL_PREFIX={install_to}',
                f'-DCMAKE_PROJECT_INCLUDE={root / PROJECT_INCLUDE}'], log, env)
    run_logged([cmake, '--build', str(build), '--parallel', str(os.cpu_count() or 1)],
               log, env)
    run_logged([cmake, '--install', str(build)], log, env)


def cached_build(root, package, key, prefix):
    """Return the cache's install tree of ``package`` at ``key``, building it if missing."""
    cache = cache_dir()
    cache.mkdir(parents=True, exist_ok=True)
    entry = cache / f'{package}-{key}'
    with open(cache / f'{package}.lock', 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # another venv may be building the same key
        if entry.is_dir():
            return entry
        missing = missing_build_wheels(prefix)
        if missing:
            raise BuildError(f'the build wheels are missing from {prefix} '
                             f'({", ".join(missing)}): run {ADD_WHEELS} first')
        print(f'{package}: building with rosidl (about a minute on 2 cores) ...', flush=True)
        work = Path(tempfile.mkdtemp(prefix=f'{package}-', dir=cache))
        try:
            cmake_build(root, package, work / 'prefix', work, prefix)
            (work / 'prefix').rename(entry)  # whole or not at all
        finally:
            shutil.rmtree(work, ignore_errors=True)
    return entry


def check_loads(package, prefix):
    """Load the type support of ``package``'s probe type in a fresh interpreter."""
    module, name = PROBES[package].rsplit('.', 1)
    code = ('from rclpy.type_support import check_for_type_support\n'
            f'from {module} import {name}\ncheck_for_type_support({name})\n')
    python = Path(prefix) / 'bin' / 'python'
    done = subprocess.run([str(python if python.exists() else sys.executable), '-c', code],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise BuildError(f'{package} installed but its types do not load:\n{done.stderr}')


def install(package, prefix, rebuild=False):
    """Make ``package`` importable from ``prefix``; return a one-line account of what it did."""
    elsewhere = provided_elsewhere(package, prefix)
    if elsewhere is not None:
        return f'{package}: provided by {elsewhere}, not built'
    root = definitions_root()
    key = build_key(root, package)
    stamp = Path(prefix) / 'share' / package / STAMP
    if not rebuild and stamp.is_file() and stamp.read_text().strip() == key:
        return f'{package}: already installed in {prefix}'
    if rebuild:
        shutil.rmtree(cache_dir() / f'{package}-{key}', ignore_errors=True)
    entry = cached_build(root, package, key, prefix)
    shutil.copytree(entry, prefix, dirs_exist_ok=True, symlinks=True)
    stamp.write_text(key + '\n')
    check_loads(package, prefix)
    return f'{package}: installed in {prefix} (build {key})'


def missing_build_wheels(prefix):
    """List the build wheels of the ``interfaces`` extra that ``prefix`` lacks (share folders)."""
    needed = ('ament_cmake', 'rosidl_default_generators', 'rosidl_generator_py',
              'python_cmake_module', 'action_msgs')
    return [name for name in needed if not (Path(prefix) / 'share' / name).is_dir()]


def main(argv=None):
    """Build and install the interface packages into this interpreter's prefix (a venv)."""
    parser = argparse.ArgumentParser(prog='rigid_sim_build_interfaces', description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--rebuild', action='store_true',
                        help='build again instead of using the per-machine cache')
    args = parser.parse_args(argv)
    prefix = Path(sys.prefix)
    started = time.monotonic()
    try:
        for package in PACKAGES:
            print(install(package, prefix, args.rebuild), flush=True)
    except BuildError as error:
        print(f'rigid_sim_build_interfaces: {error}', file=sys.stderr)
        return 1
    print(f'done in {time.monotonic() - started:.1f} s', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
