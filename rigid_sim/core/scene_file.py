# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Reading a scene or mesh file with bounded work: size, encoding, nesting and node count.

Every check here runs before the expensive step it guards: a file is measured before it is
read, a YAML text is walked as a flat stream of events (no recursion, libyaml when present)
before any Python object is built, and an alias counts as the whole node it repeats, so a
"billion laughs" file is refused at its first few kilobytes. The limits below guard the
parsing that reads a scene's own ``limits:``, so a scene cannot raise them: nesting and node
count are fixed, the file size is the operator's (``MAX_SCENE_BYTES`` by default).

Which files may be read at all is the caller's: :func:`confined` takes the directories it
allows (``roots``) and refuses any other path before it is opened, with one answer whether
or not something exists there. No message quotes what a file holds: a refusal names the
position (line and column, or the key path) and what is wrong, never the text found there,
so a file that is read by mistake (a key, a password file) is not shown to whoever named it.
"""
import os
import re
import stat
from collections.abc import Hashable

import yaml

from rigid_sim.core.text import clipped

MIB = 1 << 20
MAX_SCENE_BYTES = 16 * MIB  # default; a 100 000-body scene is about 15 MB of YAML
MAX_DEPTH = 64              # levels of nested mappings and lists; a valid scene uses 7
MAX_NODES = 2_000_000       # YAML nodes, an alias counting as the node it repeats
# YAML 1.2 (core schema) floats: 1e4, -2.5E-3 and 1.0e300 are numbers, as in ROS parameter
# files; YAML 1.1, PyYAML's default, reads an exponent without a dot as text.
YAML12_FLOAT = re.compile(r'''^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?
                             |[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$''', re.X)
FLOAT_TAG = 'tag:yaml.org,2002:float'
MERGE_TAG = 'tag:yaml.org,2002:merge'
_BASE = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)  # libyaml's C parser when built


# A quoted part of a YAML parser's message that may stay: one punctuation mark (the syntax
# expected) or a token's name such as '<block end>'; anything else quoted is the file's text.
YAML_SYNTAX = re.compile(r"'(?:[^\w\s]|<[a-z ]+>)'")
QUOTED = re.compile(r"'(?:[^'\\]|\\.)*'|\"(?:[^\"\\]|\\.)*\"")


class FileRefused(ValueError):
    """A file that is not read; ``where`` is a position or ``(file)``, ``reason`` says why."""

    def __init__(self, where, reason):
        super().__init__(f'{where}: {reason}')
        self.where, self.reason = where, reason


def confined(path, roots, what):
    """Return the real path of ``path`` if it is in one of ``roots``, else FileRefused.

    Symbolic links and ``..`` are resolved first (``os.path.realpath`` reads links, it opens
    no file), so neither leads out of a root. A path outside every root is refused exactly
    as one that does not exist, before anything there is opened: the answer tells nothing
    about files outside the roots.

    Parameters
    ----------
    path : str or os.PathLike
        Absolute, or relative to the working directory.
    roots : sequence of str or None
        Real paths of the allowed directories; None allows every file (the core used as a
        library, where the caller is the operator).
    what : str
        Words for the file in the refusal (``'mesh file'``).

    Raises
    ------
    FileRefused
        At ``(file)``: not found in the allowed directories (or not a path at all).
    """
    try:
        real = os.path.realpath(path)
    except (OSError, ValueError):  # an embedded NUL, a loop of links
        real = None
    if roots is None:
        if real is None or not os.path.lexists(real):
            raise FileRefused('(file)', f'{what} not found: {clipped(path)}')
        return real
    if real is None or not any(_inside(real, root) for root in roots) \
            or not os.path.lexists(real):
        raise FileRefused('(file)', not_found(what, roots))
    return real


def not_found(what, roots):
    """Return the one refusal of a file outside ``roots`` or missing there: it tells neither."""
    return f'{what} not found in the allowed resource directories {clipped(list(roots), 400)}'


def _inside(path, root):
    try:
        return os.path.commonpath([path, root]) == root
    except ValueError:  # one relative, one absolute
        return False


def check_file(path, max_bytes, what, limit_note=''):
    """Size in bytes of the regular file ``path`` if at most ``max_bytes``, else FileRefused.

    A FIFO, device (``/dev/zero``) or directory is refused as not a regular file before it
    is opened: reading one would block or never end. ``limit_note`` follows the size refusal
    in parentheses (what the limit counts, how to raise it).
    """
    try:
        status = os.stat(path)
    except (OSError, ValueError) as error:  # ValueError: an embedded NUL
        reason = getattr(error, 'strerror', None) or str(error)
        raise FileRefused('(file)', reason) from None
    if not stat.S_ISREG(status.st_mode):
        raise FileRefused('(file)', f'{what} is not a regular file ({_kind(status.st_mode)})')
    if status.st_size > max_bytes:
        note = f' ({limit_note})' if limit_note else ''
        raise FileRefused('(file)', f'{what} is {status.st_size} bytes, above the limit of '
                                    f'{max_bytes} bytes{note}')
    return status.st_size


def _kind(mode):
    kinds = ((stat.S_ISDIR, 'a directory'), (stat.S_ISFIFO, 'a FIFO'),
             (stat.S_ISCHR, 'a character device'), (stat.S_ISBLK, 'a block device'),
             (stat.S_ISSOCK, 'a socket'))
    return next((name for test, name in kinds if test(mode)), 'a special file')


def read_text(path, max_bytes, what, limit_note=''):
    """Read the UTF-8 text of the regular file ``path``, at most ``max_bytes``, or FileRefused.

    ``limit_note`` is :func:`check_file`'s.
    """
    check_file(path, max_bytes, what, limit_note)
    try:
        with open(path, 'rb') as stream:
            data = stream.read(max_bytes + 1)  # the file may have grown since the check
    except OSError as error:
        raise FileRefused('(file)', f'{what}: {error.strerror or error}') from None
    if len(data) > max_bytes:
        raise FileRefused('(file)', f'{what} is above the limit of {max_bytes} bytes')
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as error:
        raise FileRefused(f'byte {error.start}', f'{what} is not UTF-8 text '
                                                 f'({error.reason})') from None


class SceneLoader(_BASE):
    """PyYAML's safe loader with YAML 1.2 floats, refusing a key given twice in one mapping.

    PyYAML keeps the last of two equal keys silently; a scene that says ``mass`` twice is
    a mistake whichever one was meant. Merge keys (``<<: *defaults``) work as in YAML: a key
    written beside one overrides the merged key, which is no duplicate.
    """

    yaml_implicit_resolvers = {
        first: [resolver for resolver in resolvers if resolver[0] != FLOAT_TAG]
        for first, resolvers in _BASE.yaml_implicit_resolvers.items()}

    def __init__(self, stream):
        super().__init__(stream)
        self._resolved = {}   # (value, implicit) -> tag of a plain scalar

    def resolve(self, kind, value, implicit):
        # A scene repeats its keys and many values in every body: resolving each text once
        # (the resolver tries a regular expression per candidate type) halves the load time
        # of 10 000 bodies. Only scalars are cached; their tag depends on nothing else here.
        if kind is not yaml.ScalarNode:
            return super().resolve(kind, value, implicit)
        key = (value, implicit)
        tag = self._resolved.get(key)
        if tag is None:
            tag = self._resolved[key] = super().resolve(kind, value, implicit)
        return tag

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            # A merge key (<<) brings in another mapping's keys, which the keys written
            # beside it override, as YAML says; the base class merges them. Its expansion
            # was counted by check_structure, as an alias counts as what it repeats.
            if key_node.tag == MERGE_TAG:
                continue
            key = self.construct_object(key_node, deep=deep)
            if not isinstance(key, Hashable):
                continue  # the base class refuses it, saying so
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, 'duplicate key', key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep)


SceneLoader.add_implicit_resolver(FLOAT_TAG, YAML12_FLOAT, list('-+0123456789.'))


def where(mark):
    """``line L, column C`` of a YAML mark (1-based)."""
    return f'line {mark.line + 1}, column {mark.column + 1}'


def check_structure(text):
    """Raise FileRefused if the YAML ``text`` nests deeper than MAX_DEPTH or exceeds MAX_NODES.

    Walks the parser's events with a stack, never recursing; an alias adds the size and
    height its anchor had. Syntax errors are left to the loader, which reports them.
    """
    stack = []      # per open collection: [nodes, height, anchor]
    anchored = {}   # anchor -> (nodes, height)
    loader = SceneLoader(text)
    try:
        while loader.check_event():
            event = loader.get_event()
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                _refuse_depth(len(stack) + 1, event)
                stack.append([1, 1, event.anchor])
            elif isinstance(event, yaml.CollectionEndEvent):
                nodes, height, anchor = stack.pop()
                _add(stack, anchored, anchor, nodes, height, event)
            elif isinstance(event, yaml.ScalarEvent):
                _add(stack, anchored, event.anchor, 1, 1, event)
            elif isinstance(event, yaml.AliasEvent):
                nodes, height = anchored.get(event.anchor, (1, 1))
                _add(stack, anchored, None, nodes, height, event)
    finally:
        loader.dispose()


def _add(stack, anchored, anchor, nodes, height, event):
    """Count a finished node of ``nodes`` nodes and ``height`` levels into its parent."""
    if anchor is not None:
        anchored[anchor] = (nodes, height)
    if not stack:
        return
    _refuse_depth(len(stack) + height, event)
    parent = stack[-1]
    parent[0] += nodes
    parent[1] = max(parent[1], height + 1)
    if parent[0] > MAX_NODES:
        raise FileRefused(where(event.start_mark), f'more than {MAX_NODES} YAML nodes '
                                                   '(aliases counted as what they repeat)')


def _refuse_depth(depth, event):
    if depth > MAX_DEPTH:
        raise FileRefused(where(event.start_mark),
                          f'nested deeper than {MAX_DEPTH} levels of mappings and lists')


def load_yaml(path, max_bytes=MAX_SCENE_BYTES, limit_note=''):
    """Parse the YAML document of the scene file ``path``, within the limits above.

    ``max_bytes`` bounds the file's size; ``limit_note`` says who sets it, as
    :func:`check_file` takes it.

    Raises
    ------
    FileRefused
        Naming the position (or ``(file)``) and the reason: not a regular file, too big,
        not UTF-8, nested too deep, too many nodes, or invalid YAML.
    """
    return parse_yaml(read_text(path, max_bytes, 'scene file', limit_note))


def parse_yaml(text, max_bytes=MAX_SCENE_BYTES):
    """Parse a YAML document given as text (a scene's, or one body entry), within the limits.

    Raises FileRefused as :func:`load_yaml` does, for all but the file checks.
    """
    if len(text) > max_bytes:
        raise FileRefused('(text)', f'{len(text)} characters, above the limit of '
                                    f'{max_bytes} bytes of a scene')
    try:
        check_structure(text)
        return yaml.load(text, Loader=SceneLoader)
    except FileRefused:
        raise
    except yaml.MarkedYAMLError as error:
        context = (f' ({error.context} from {where(error.context_mark)})'
                   if error.context and error.context_mark else '')
        mark = error.problem_mark or error.context_mark
        raise FileRefused(where(mark) if mark else '(file)',
                          f'invalid YAML: {syntax_only(error.problem)}'
                          f'{syntax_only(context)}') from None
    except yaml.reader.ReaderError as error:
        raise FileRefused(f'character {error.position}', 'invalid YAML: unacceptable '
                          f'character ({error.reason})') from None
    except yaml.YAMLError as error:
        raise FileRefused('(file)', f'invalid YAML ({type(error).__name__})') from None
    except Exception as error:  # a constructor on a value it cannot hold: 5000 digits, Feb 30
        raise FileRefused('(file)', f'invalid YAML value ({type(error).__name__}: a number '
                                    'too long, a date that does not exist, ...)') from None


def syntax_only(problem):
    """Return a YAML parser's ``problem`` without the text of the file it quotes.

    PyYAML quotes what it found (a character, an undefined alias, a tag), each replaced by
    ``(...)``; the syntax it expected (``expected ',' or '}'``) stays.
    """
    def keep_syntax(match):
        return match.group(0) if YAML_SYNTAX.fullmatch(match.group(0)) else '(...)'
    return clipped(QUOTED.sub(keep_syntax, problem or ''), 400)
