# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Lint as tests, as ament_python packages carry them, plus the repository's own two rules.

``ament_flake8`` (99 columns) and ``ament_pep257`` run on every Python file; every such file
starts with the copyright and SPDX lines; and no file names a document the repository does
not hold, so a clone is all a reader needs. CONTRIBUTING.md says how to run each by hand.
"""
import os
from pathlib import Path
import re
import subprocess
import sys

from ament_pep257.main import main as pep257_main
import pytest

ROOT = Path(__file__).resolve().parents[1]
# Python sources of the package, its tests, its setup script and any launch files.
PYTHON_PATHS = [name for name in ('rigid_sim', 'test', 'setup.py', 'launch')
                if (ROOT / name).exists()]
# ament's pep257 convention, with numpydoc's choices where the two differ (as scipy and
# trimesh write it): the summary on the line of the opening quotes (D212 instead of D213),
# and no blank line required after the last section (D413).
PEP257_OPTIONS = ['--add-ignore', 'D213', 'D413', '--add-select', 'D212']
HEADER = ('# Copyright 2026 rigid_sim maintainers\n'
          '# SPDX-License-Identifier: Apache-2.0\n')
# Files whose text may name a document: everything but images, meshes and build output.
TEXT_SUFFIXES = {'.py', '.md', '.yaml', '.yml', '.xml', '.cfg', '.ini', '.txt', '.toml'}
SKIPPED_DIRS = {'build', 'install', 'log', '__pycache__'}
URL = re.compile(r'\w+://\S+')
MARKDOWN_PATH = re.compile(r'[\w./-]*[\w-]\.md\b')
# A bare name of notes (``<TOPIC>_NOTES``): notes the repository holds are docs/*.md pages.
NOTES_NAME = re.compile(r'\b[A-Z]+_NOTES\b')
# This file spells out what it forbids, as patterns and as examples.
THIS_FILE = Path(__file__).resolve()


def python_files():
    """Every .py file the lint rules cover, sorted."""
    files = []
    for name in PYTHON_PATHS:
        path = ROOT / name
        files.extend(sorted(path.rglob('*.py')) if path.is_dir() else [path])
    return files


def text_files():
    """Every text file of the repository, outside hidden and build directories."""
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = sorted(d for d in dirs if not d.startswith('.') and d not in SKIPPED_DIRS
                         and not d.endswith('.egg-info'))
        for name in sorted(files):
            path = Path(folder) / name
            if path.suffix in TEXT_SUFFIXES and path.resolve() != THIS_FILE:
                yield path


def missing_documents(text, folder, root=ROOT):
    """Names in ``text`` of documents that the repository at ``root`` does not hold.

    Parameters
    ----------
    text : str
        Contents of one file.
    folder : pathlib.Path
        Directory of that file. A .md path may be relative to it or to ``root``; a bare
        file name (joined to a directory in code) may name any file of ``root``.
    root : pathlib.Path
        The repository; a path that leaves it is missing even if it exists.

    Returns
    -------
    list of str
        Each offending name, in order of appearance.
    """
    text = URL.sub('', text)
    missing = [match.group() for match in NOTES_NAME.finditer(text)]
    for name in (match.group() for match in MARKDOWN_PATH.finditer(text)):
        if '/' in name:
            candidates = [(folder / name).resolve(), (root / name).resolve()]
        else:
            candidates = list(root.rglob(name))
        if not any(path.is_file() and path.is_relative_to(root) for path in candidates):
            missing.append(name)
    return missing


# flake8 checks files in worker processes it forks; forked from the suite's process, whose
# other threads (rclpy's, the node's workers) may hold a lock at that moment, a worker can
# wait on it forever. A fresh interpreter has no other thread.
FLAKE8 = ('import sys; from ament_flake8.main import main_with_errors; '
          'rc, errors = main_with_errors(sys.argv[1:]); print(*errors, sep="\\n"); sys.exit(rc)')


@pytest.mark.linter
def test_flake8():
    """ament_flake8 finds nothing in any Python file of the package."""
    done = subprocess.run([sys.executable, '-c', FLAKE8, *PYTHON_PATHS], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f'flake8 errors:\n{done.stdout}{done.stderr}'[-5000:]


@pytest.mark.linter
def test_pep257(monkeypatch, capsys):
    """ament_pep257 finds nothing in any docstring of the package."""
    monkeypatch.chdir(ROOT)
    rc = pep257_main(argv=PYTHON_PATHS + PEP257_OPTIONS)
    assert rc == 0, capsys.readouterr().err


@pytest.mark.linter
def test_every_python_file_starts_with_the_copyright_header():
    """Each file opens with the copyright line and the SPDX licence identifier."""
    files = python_files()
    assert len(files) > 10  # the walk found the package, not an empty directory
    wrong = [str(path.relative_to(ROOT)) for path in files
             if not path.read_text(encoding='utf-8').startswith(HEADER)]
    assert not wrong, 'missing or wrong header:\n' + '\n'.join(wrong)


@pytest.mark.linter
def test_no_file_names_a_document_the_repository_lacks():
    """Every .md path resolves inside the repository and no outside note is named."""
    cited = {}
    for path in text_files():
        names = missing_documents(path.read_text(encoding='utf-8'), path.parent)
        if names:
            cited[str(path.relative_to(ROOT))] = names
    assert not cited, f'documents not in the repository: {cited}'


def test_the_document_check_catches_what_it_is_for(tmp_path):
    """A missing .md, a path out of the repository and an outside note are all caught."""
    (tmp_path / 'docs').mkdir()
    (tmp_path / 'docs' / 'held.md').write_text('')
    text = ('see docs/held.md, held.md, ../docs/held.md and ../../elsewhere/notes.md; '
            'docs/gone.md, gone.md; https://example.com/remote.md; LAB_NOTES')
    assert missing_documents(text, tmp_path / 'docs', root=tmp_path) == [
        'LAB_NOTES', '../../elsewhere/notes.md', 'docs/gone.md', 'gone.md']


# An issue of the tracker, as a page might cite it ("issue 12", "issues 6 and 12", "#12"):
# a reader of the repository cannot open one, so pages say what they mean instead.
ISSUE_CITATION = re.compile(r'\b[Ii]ssues? ?#?\d+|(?<![\w&])#\d+\b')


def issue_citations(text):
    """Every citation of a tracker issue in ``text`` (URLs apart)."""
    return [match.group() for match in ISSUE_CITATION.finditer(URL.sub('', text))]


@pytest.mark.linter
def test_no_document_cites_an_issue_number():
    """README, CONTRIBUTING and docs/ say what they mean, never 'issue 12'."""
    pages = [ROOT / 'README.md', ROOT / 'CONTRIBUTING.md', *sorted((ROOT / 'docs').glob('*.md'))]
    cited = {str(page.relative_to(ROOT)): issue_citations(page.read_text(encoding='utf-8'))
             for page in pages}
    assert not {page: names for page, names in cited.items() if names}


def test_the_issue_check_catches_what_it_is_for():
    """Each way of citing an issue is caught; headings, colours and numbers are not."""
    text = ('as issue 12 asked; issues 6 and 12; see #34; Issue #5.\n'
            '## Heading 2\ncolour &#38; value 1e4 and N = 100')
    assert issue_citations(text) == ['issue 12', 'issues 6', '#34', 'Issue #5']
