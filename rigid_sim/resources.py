# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Finding packaged data (config, interfaces): source tree, pip and colcon install alike.

``config/`` is installed to ``share/rigid_sim/config``. Where that share directory is
depends on how the package was installed:

- colcon (or any ROS install): the ament index finds it through ``AMENT_PREFIX_PATH``;
- ``pip install .`` into a prefix or venv: ``<prefix>/share/rigid_sim``, next to the
  ``lib/python3.X/site-packages`` that holds this module;
- the source tree (``pip install -e .`` installs no data files, and a plain venv has no
  ``AMENT_PREFIX_PATH``): ``config/`` beside the ``rigid_sim`` package directory.

Files a client names (the ``scene`` parameter, SpawnEntity's ``uri``, the meshes they use)
are read only from the allowed directories: the packaged ``config/`` and the operator's
``resource_paths`` (:func:`allowed_roots`); anything else is refused unopened, with the
answer a missing file gets.
"""
import os
import sys
from pathlib import Path

from rigid_sim.core.scene_file import confined, FileRefused
from rigid_sim.core.text import shown

PACKAGE = 'rigid_sim'
DEFAULT_SCENE = 'default.yaml'
# The operator's directories when none are given: the working directory (the packaged
# config/ is allowed always).
DEFAULT_RESOURCE_PATHS = ('.',)
_PACKAGE_DIR = Path(__file__).resolve().parent


def _ament_share():
    """Return the share directory the ament index knows, or None outside a ROS environment."""
    try:
        from ament_index_python.packages import (PackageNotFoundError,
                                                 get_package_share_directory)
    except ImportError:
        return None
    try:
        return Path(get_package_share_directory(PACKAGE))
    except (PackageNotFoundError, OSError):  # OSError: no AMENT_PREFIX_PATH (plain venv)
        return None


def package_share(name):
    """Return the share directory of ROS package ``name`` by the ament index, or None.

    For ``package://`` URIs; what is read there must still lie in an allowed directory.
    """
    try:
        from ament_index_python.packages import (PackageNotFoundError,
                                                 get_package_share_directory)
    except ImportError:
        return None
    try:
        return get_package_share_directory(name)
    except (PackageNotFoundError, OSError, ValueError):
        return None


def config_directories():
    """Directories that may hold the packaged ``config/``, most specific first.

    Returns
    -------
    list of Path
        Existing directories only.
    """
    return packaged_directories('config')


def packaged_directories(folder):
    """Directories that may hold the packaged ``folder`` (``config``, ``interfaces``).

    Returns
    -------
    list of Path
        Existing directories only, most specific first.
    """
    source_tree = _PACKAGE_DIR.parent
    # <prefix>/lib/python3.X/site-packages/rigid_sim -> <prefix>
    install_prefix = _PACKAGE_DIR.parents[3] if len(_PACKAGE_DIR.parents) > 3 else None
    candidates = [_ament_share()]
    if (source_tree / 'package.xml').is_file():
        candidates.append(source_tree)
    if install_prefix is not None:
        candidates.append(install_prefix / 'share' / PACKAGE)
    candidates.append(Path(sys.prefix) / 'share' / PACKAGE)
    found = []
    for share in candidates:
        if share is not None and (share / folder).is_dir() and share / folder not in found:
            found.append(share / folder)
    return found


def allowed_roots(resource_paths=DEFAULT_RESOURCE_PATHS):
    """Real paths of the directories files may be read from: packaged config, then the operator's.

    Parameters
    ----------
    resource_paths : sequence of str
        The operator's directories (parameter ``resource_paths``); relative ones start at
        the working directory. Symbolic links are resolved, so a root is compared as the
        files in it will be.

    Returns
    -------
    list of str
    """
    roots = [os.path.realpath(folder) for folder in config_directories()]
    for folder in resource_paths:
        real = os.path.realpath(os.path.expanduser(folder))
        if real not in roots:
            roots.append(real)
    return roots


def find_scene(name, resource_paths=DEFAULT_RESOURCE_PATHS):
    """Real path of the scene file ``name``, in the allowed directories only.

    An absolute path is taken as it is; a relative one is looked up in each of the
    operator's ``resource_paths`` (the working directory by default), then in the
    packaged ``config`` (README) and ``config/scenes``, where the shipped scenes are. The
    first place where something exists and that lies in an allowed directory (symbolic
    links and ``..`` resolved) is the answer: a FIFO or directory is then refused by the
    loader as not a regular file. A path outside the allowed directories is never opened.

    Raises
    ------
    FileNotFoundError
        The same words whether the file does not exist or lies outside the allowed
        directories (or the name is no path at all).
    """
    roots = allowed_roots(resource_paths)
    path = Path(name).expanduser() if '\0' not in name else None
    if path is not None and path.is_absolute():
        candidates = [path]
    elif path is not None:
        packaged = [Path(folder) for config in config_directories()
                    for folder in (config, config / 'scenes')]
        operator = [Path(folder).expanduser() for folder in resource_paths]
        candidates = [folder / path for folder in operator + packaged]
    else:
        candidates = []
    for candidate in candidates:
        try:
            return Path(confined(candidate, roots, 'scene file'))
        except FileRefused:
            continue
    raise FileNotFoundError(f'scene file {shown(name)} not found in the allowed resource '
                            f'directories {shown(roots, 400)} (parameter resource_paths)')
