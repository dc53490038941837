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
"""
import os
import sys
from pathlib import Path

from rigid_sim.core.text import clipped, shown

PACKAGE = 'rigid_sim'
DEFAULT_SCENE = 'default.yaml'
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


def find_scene(name):
    """Path of the scene file ``name``.

    An absolute path, or a path relative to the working directory, is taken as it is, as
    soon as something exists there (a FIFO or directory is then refused by the loader as
    not a regular file, not reported missing); a bare file name not found there is looked
    up in the packaged ``config`` (README), then in ``config/scenes``, where the shipped
    scenes are.

    Raises
    ------
    FileNotFoundError
        Naming every place that was searched, or why the name is no path at all.
    """
    try:
        return _find(name)
    except (OSError, ValueError) as error:  # an embedded NUL, a name too long, ...
        if isinstance(error, FileNotFoundError):
            raise
        raise FileNotFoundError(f'scene file {shown(name)}: {clipped(error)}') from None


def _find(name):
    path = Path(name).expanduser()
    if os.path.lexists(path):
        return path.resolve()
    searched = [clipped(path.resolve())]
    if not path.is_absolute() and len(path.parts) == 1:
        for folder in (folder for config in config_directories()
                       for folder in (config, config / 'scenes')):
            packaged = folder / path
            if packaged.is_file():
                return packaged
            searched.append(clipped(packaged))
    raise FileNotFoundError(f'scene file {shown(name)} not found; searched {searched}')
