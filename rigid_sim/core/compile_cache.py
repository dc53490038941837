# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""numba's disk cache of the core's kernels, keyed on the bytes of every core source.

numba's ``cache=True`` checks only the source file of the kernel it loads, but the core's
kernels inline compiled functions of other modules (kinematics, special functions, the
effects): after one of those changes, an untouched caller would load machine code built
against the old callee, which can crash the process. So the cache lives in a directory
named by a hash of every ``rigid_sim/core/**/*.py`` file and numba's version; any edit of
the core, or another numba, starts a fresh directory. It sits under ``NUMBA_CACHE_DIR``
when the user set it, else under the user's cache directory (``XDG_CACHE_HOME``, else
``~/.cache``), as ``rigid_sim/numba/<key>``, never in the package tree, so a read-only
install (/opt/ros) caches too. numba's setting is process-wide: other numba code imported
in the same process caches there as well.
"""
import atexit
import hashlib
import os
from pathlib import Path
import re
import shutil
import tempfile
import time

import numba
from numba.core import config

CORE = Path(__file__).resolve().parent
KEY_LENGTH = 16   # hex digits of the hash: enough to tell versions apart
KEY = re.compile(f'[0-9a-f]{{{KEY_LENGTH}}}')
# A keyed directory no process has used for this long belongs to an old version.
STALE_AFTER = 30 * 24 * 3600.0   # s


def source_key(core=CORE, numba_version=numba.__version__):
    """Hash of the path and bytes of every .py file under ``core``, and of numba's version.

    Parameters
    ----------
    core : pathlib.Path
        Directory of the core's sources; the key depends on the files' paths relative to
        it and their contents, not on where it is.
    numba_version : str
        Version of the numba that compiles the kernels.

    Returns
    -------
    str
        ``KEY_LENGTH`` lower-case hex digits.
    """
    digest = hashlib.sha256(numba_version.encode())
    for path in sorted(core.rglob('*.py')):
        digest.update(path.relative_to(core).as_posix().encode() + b'\0')
        digest.update(path.read_bytes() + b'\0')
    return digest.hexdigest()[:KEY_LENGTH]


def cache_root(environ=os.environ):
    """Directory holding one keyed cache directory per version of the core's sources."""
    root = environ.get('NUMBA_CACHE_DIR') or environ.get('XDG_CACHE_HOME')
    return Path(root or Path.home() / '.cache') / 'rigid_sim' / 'numba'


def prune(root, keep, now=None):
    """Delete the keyed directories under ``root``, ``keep`` excepted, unused for long.

    Long is ``STALE_AFTER``. Only names shaped like a key are touched, and a directory any
    process used recently stays (several checkouts of different versions may share
    ``root``).
    """
    now = time.time() if now is None else now
    for entry in root.iterdir():
        if entry.name == keep or not KEY.fullmatch(entry.name):
            continue
        try:
            stale = entry.is_dir() and now - entry.stat().st_mtime > STALE_AFTER
        except OSError:   # another process pruned it first
            continue
        if stale:
            shutil.rmtree(entry, ignore_errors=True)


def use_keyed_cache(environ=os.environ):
    """Point numba's cache at the directory keyed on the core's sources; that directory.

    Must run before any kernel module is imported: numba fixes a kernel's cache location
    when it decorates it. Where the directory cannot be made (no writable home), a private
    temporary one is used for this process only, so nothing stale is ever loaded.
    """
    key = source_key()
    root = cache_root(environ)
    directory = root / key
    try:
        directory.mkdir(parents=True, exist_ok=True)
        os.utime(directory)   # marks it used, for prune
    except OSError:
        directory = Path(tempfile.mkdtemp(prefix='rigid_sim_numba_'))
        atexit.register(shutil.rmtree, directory, ignore_errors=True)
    else:
        prune(root, key)
    config.CACHE_DIR = str(directory)
    return directory
