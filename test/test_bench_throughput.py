# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench throughput`` runs end to end on its quick configuration."""
import math

from rigid_sim.bench import cli
from rigid_sim.bench.body_threads import METHODS
from rigid_sim.bench.throughput import GUARDED, QUICK, UNESTIMATED
from rigid_sim.core.integrators import REGISTRY


def table_rows(text, title):
    """``{first cell: other cells}`` of the Markdown table under the heading ``title``."""
    block = text.split(title, 1)[1].split('###', 1)[0]
    rows = [line.split('|')[1:-1] for line in block.splitlines()
            if line.startswith('| ') and '---' not in line]
    return {cells[0].strip(): [cell.strip() for cell in cells[1:]] for cells in rows[1:]}


def test_quick_throughput_reports_every_integrator(tmp_path, capsys):
    """Every registered integrator has a positive, finite time per body-step at each N.

    So have the methods that skip their estimate when nothing reads it, without it, and
    MuJoCo's Euler and RK4, installed with the test extra; each effect's cost is listed;
    the world without effects made no call into effect code; the Markdown section and the plot
    are written, keeping hand-written text around the section; the wall-clock table has each
    method in one call and on threads, and MuJoCo RK4 with its ratios.
    """
    out = tmp_path / 'performance.md'
    out.write_text('# Hand-written title\n')
    parser = cli.build_parser()
    args = parser.parse_args(['throughput', '--quick', '--out', str(out)])
    results = args.run(args)
    printed = capsys.readouterr().out
    per_body_step = table_rows(printed, 'CPU time per body-step')
    expected = set(REGISTRY) | set(GUARDED) | set(UNESTIMATED) | {'mujoco Euler', 'mujoco RK4'}
    assert set(UNESTIMATED.values()) == {'euler', 'rk4', 'rk4_world', 'semi_implicit_euler',
                                         'dlm4', 'exact_split4'}
    assert set(per_body_step) == expected
    for name, cells in per_body_step.items():
        assert len(cells) == len(QUICK['sizes'])
        assert all(0.0 < float(cell) < math.inf for cell in cells), name
    assert set(results) == expected
    effects = table_rows(printed, 'of each effect')
    assert set(effects) == {'gravity', 'damping', 'springs', 'wrench'}
    assert 'made 0 calls into' in printed
    walls = table_rows(printed, 'Wall time per body-step')
    assert set(walls) == {f'{name}, {kind}' for name in METHODS
                          for kind in ('one thread', 'threads')} | {'mujoco RK4'}
    for name, cells in walls.items():
        assert len(cells) == len(QUICK['thread_sizes'])
        assert all(0.0 < float(cell) < math.inf for cell in cells), name
    assert set(table_rows(printed, 'MuJoCo RK4 wall time')) == set(walls) - {'mujoco RK4'}
    written = out.read_text()
    assert written.startswith('# Hand-written title')
    assert table_rows(written, 'CPU time per body-step') == per_body_step
    assert (tmp_path / 'performance.png').read_bytes()[:4] == b'\x89PNG'
