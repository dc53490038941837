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

The cache never stops a start. numba raises whatever unpickling a damaged file raises
(a truncated ``.nbc``, a garbage ``.nbi``: ``UnpicklingError``, ``EOFError``) out of the
kernel's first call, so every cache here is a :class:`HealingCache`: an entry that fails to
load is deleted and its kernel compiled (and cached) again. Where the directory cannot be
made or written (``NUMBA_CACHE_DIR`` naming a file, no writable home) nothing is cached
in this process, rather than in a temporary directory that a stop by signal would leave
behind, or in the package tree, where numba's own fallback would be unkeyed. Each of these
is logged once, as a warning of the ``rigid_sim.core.compile_cache`` logger.
"""
import glob
import hashlib
import logging
import os
from pathlib import Path
import re
import shutil
import tempfile
import time

import numba
from numba.core import caching, config, dispatcher

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


class CacheState:
    """Where this process caches the core's kernels, or why it does not, and what it warned."""

    def __init__(self):
        self.directory = None   # pathlib.Path of the keyed directory, None: not cached
        self.problem = None     # why nothing is cached, for the log
        self.healed = 0         # damaged entries deleted (and compiled again)
        self._warned = set()

    def warn_once(self, kind, text):
        """Log ``text`` as a warning, unless one of this ``kind`` was logged before."""
        if kind not in self._warned:
            self._warned.add(kind)
            LOG.warning(text)

    def give_up(self, directory, error):
        """Cache nothing from now on: ``directory`` cannot be used, ``error`` says why."""
        self.directory = None
        self.problem = f'{directory} cannot be used ({error.strerror or error})'
        self.warn_once('unusable', f'the compiled kernels will not be cached: {self.problem}; '
                                   'every start compiles them again (set NUMBA_CACHE_DIR or '
                                   'XDG_CACHE_HOME to a writable directory)')


LOG = logging.getLogger(__name__)
STATE = CacheState()


class HealingCache(caching.FunctionCache):
    """numba's per-kernel disk cache, treating an entry it cannot load as one to rebuild."""

    def load_overload(self, sig, target_context):
        """Load the kernel for ``sig``; None (compile it) if absent or damaged."""
        try:
            return super().load_overload(sig, target_context)
        except Exception as error:   # any failure to read back a cache file is damage
            base = self._impl.filename_base
            for path in Path(self.cache_path).glob(glob.escape(base) + '.*'):
                path.unlink(missing_ok=True)
            STATE.healed += 1
            STATE.warn_once('damaged', f'the kernel cache in {self.cache_path} held a damaged '
                                       f'entry ({base}: {type(error).__name__}: {error}); '
                                       'damaged entries are deleted and compiled again')
            return None

    def save_overload(self, sig, data):
        """Cache the kernel compiled for ``sig``; if the directory fails, stop caching."""
        try:
            super().save_overload(sig, data)
        except OSError as error:   # a full disk, a directory removed or made read-only
            STATE.give_up(self.cache_path, error)
            dispatcher.FunctionCache = _null_cache


def _null_cache(py_func):
    """No disk cache for ``py_func``'s kernels: what numba gives a kernel without cache=True."""
    return caching.NullCache()


def _writable_directory(directory):
    """Make ``directory`` if need be and check that a file can be written in it (OSError)."""
    directory.mkdir(parents=True, exist_ok=True)
    tempfile.TemporaryFile(dir=directory).close()
    os.utime(directory)   # marks it used, for prune


def use_keyed_cache(environ=os.environ):
    """Point numba's cache at the directory keyed on the core's sources; that directory.

    Must run before any kernel module is imported: numba gives a kernel its cache when it
    decorates it. Returns None, after a warning, where the directory cannot be made or
    written: then kernels are compiled in memory only (:data:`STATE` says why).
    """
    key = source_key()
    root = cache_root(environ)
    directory = root / key
    try:
        _writable_directory(directory)
    except OSError as error:
        STATE.give_up(directory, error)
        dispatcher.FunctionCache = _null_cache
        return None
    try:
        prune(root, key)
    except OSError:   # an unreadable root: old directories stay, nothing else is lost
        pass
    config.CACHE_DIR = str(directory)
    STATE.directory = directory
    dispatcher.FunctionCache = HealingCache
    return directory


def caching_note():
    """Words for a log line about kernels being compiled now: where they are cached, or why not.

    ``cached afterwards in <directory>``, or ``not cached: <directory> cannot be used
    (<reason>)`` where this process caches nothing.
    """
    if STATE.problem is not None:
        return f'not cached: {STATE.problem}'
    return f'cached afterwards in {STATE.directory}'
