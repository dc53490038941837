# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Benchmarks behind the ``rigid_sim_bench`` console script, and what they share.

Subcommands: ``accuracy`` (:mod:`.accuracy`), ``inertia`` (:mod:`.inertia_cost`),
``stability`` (:mod:`.stability`), ``throughput`` (:mod:`.throughput`), ``node``
(:mod:`.node_rate`), ``imu`` (:mod:`.imu_cost`) and ``goals`` (:mod:`.goals`). CPU time
is ``time.process_time`` (this process's user + system time), so other load on the machine
does not count against a method.
"""
import datetime
import os
import platform
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy


class MissingPackage(RuntimeError):
    """An optional package a benchmark option needs is not installed."""


class OverBudget(Exception):
    """The first timed run shows that all the repeats would exceed the CPU budget."""


def median_cpu_time(prepare, repeats, budget=np.inf, clock=time.process_time):
    """Median CPU seconds of ``repeats`` runs and the last run's result.

    ``prepare()`` does the untimed setup and returns the zero-argument callable to time.
    Raises OverBudget (its argument: the first run's seconds) when ``repeats`` times the
    first run exceeds ``budget``. ``clock``: ``time.perf_counter`` for wall seconds.
    """
    times = []
    result = None
    for _ in range(repeats):
        run = prepare()
        start = clock()
        result = run()
        times.append(clock() - start)
        if times[0] * repeats > budget:
            raise OverBudget(times[0])
    return float(np.median(times)), result


def scientific(value, digits=2):
    """``1.23e-04`` style, ``-`` for NaN, ``diverged`` for inf."""
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return '-'
    if np.isinf(value):
        return 'diverged'
    return f'{value:.{digits}e}'


def markdown_table(header, rows):
    """Return a GitHub Markdown table from a header (K,) and rows of K strings.

    A ``|`` inside a cell (``|omega|``, ``|L|``) is escaped, or it would split the column.
    """
    def line(cells):
        return '| ' + ' | '.join(str(cell).replace('|', r'\|') for cell in cells) + ' |'
    return '\n'.join([line(header), '|' + ' --- |' * len(header)] + [line(row) for row in rows])


def machine_description(extra_versions=()):
    """Markdown lines: CPU model and count, Python and library versions, date (UTC)."""
    try:
        lscpu = subprocess.run(['lscpu'], capture_output=True, text=True, check=False).stdout
        model = re.search(r'Model name:\s*(.+)', lscpu).group(1).strip()
    except (OSError, AttributeError):
        model = platform.processor() or 'unknown'
    versions = [f'Python {platform.python_version()}', f'numpy {np.__version__}',
                f'scipy {scipy.__version__}'] + list(extra_versions)
    date = datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')
    return [f'- Machine: {model}, {os.cpu_count()} logical cores, {platform.system()}',
            f'- Versions: {", ".join(versions)}',
            f'- Date: {date}',
            '- CPU time: `time.process_time` (this process only), median of the repeats']


def command_line():
    """Return the command as typed, for the record."""
    return 'rigid_sim_bench ' + ' '.join(sys.argv[1:])


def write_section(path, name, body):
    """Replace the ``name`` section of the Markdown file at ``path`` (append it if absent).

    A section lies between ``<!-- name: begin -->`` and ``<!-- name: end -->``, so text
    written by hand around it survives a rerun.
    """
    path = Path(path)
    begin, end = f'<!-- {name}: begin -->', f'<!-- {name}: end -->'
    block = f'{begin}\n{body.strip()}\n{end}'
    text = path.read_text() if path.exists() else ''
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = (text.rstrip() + '\n\n' if text.strip() else '') + block + '\n'
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
