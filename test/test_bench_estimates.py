# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The error-estimate benchmark runs end to end, and its verdicts can fail.

The ``--quick`` configuration must give every registered integrator a column on every case,
so an integrator added to the registry without an estimate the benchmark can read fails here.
"""
import numpy as np

from rigid_sim.bench import cli, estimates
from rigid_sim.core.integrators import REGISTRY

TABLE_HEADING = '### Estimate / true local error'


def ratio_table(markdown):
    """Return the first table after the ratio heading: {case: {method: cell}}."""
    lines = markdown.split(TABLE_HEADING, 1)[1].splitlines()
    rows = [line for line in lines if line.startswith('| ')]
    header = [cell.strip() for cell in rows[0].strip('|').split('|')]
    table = {}
    for line in rows[1:]:
        if line.startswith('| ---'):
            continue
        if line.startswith('| case'):
            break
        cells = [cell.strip() for cell in line.strip('|').split('|')]
        table[cells[0]] = dict(zip(header[1:], cells[1:]))
    return table


def run(tmp_path, *options):
    """Run ``rigid_sim_bench estimates --quick`` with ``options``; (bare, control, printed)."""
    args = cli.build_parser().parse_args(['estimates', '--quick', '--out',
                                          str(tmp_path / 'accuracy.md'), *options])
    bare, control = args.run(args)
    return bare, control, (tmp_path / 'accuracy.md').read_text()


def test_quick_benchmark_has_every_integrator_on_every_case(tmp_path):
    """A cell per registered integrator and quick case; the plot and section are written.

    On the spring at the centre of mass (omega dt = 0.063) Heun's difference is Euler's own
    leading local error ``h^2/2 y''``: the ratio is 1 to within the next term, ~omega dt.
    """
    (tmp_path / 'accuracy.md').write_text('# Hand-written title\n')
    bare, control, written = run(tmp_path)
    assert written.startswith('# Hand-written title')
    table = ratio_table(written)
    assert set(table) == set(estimates.QUICK['cases'])
    for case, cells in table.items():
        assert set(cells) == set(REGISTRY), case
        assert all(cells.values()), case
    assert (tmp_path / estimates.PLOT_NAME).read_bytes()[:4] == b'\x89PNG'
    assert len(control) == len(bare) * len(estimates.TOLERANCES)
    euler = estimates.ratios(bare['euler', 'acc_spring'])
    assert len(euler) == estimates.QUICK['samples']
    assert np.all(np.abs(np.log(euler)) < 0.15), euler


def test_an_estimate_a_hundred_times_too_small_is_listed_loudly(tmp_path, monkeypatch):
    """Dividing semi-implicit Euler's estimate by 100 must flag it as a silent underestimate.

    Unchanged, its estimate of the spring's error is its own leading error (ratio ~1).
    """
    options = ('--cases', 'acc_spring', '--methods', 'semi_implicit_euler')
    _, _, honest = run(tmp_path, *options)
    assert 'UNDER' not in ratio_table(honest)['acc_spring']['semi_implicit_euler']
    read = estimates.estimate_of
    monkeypatch.setattr(estimates, 'estimate_of', lambda world: read(world) / 100.0)
    bare, _, written = run(tmp_path, *options)
    assert 'UNDER' in ratio_table(written)['acc_spring']['semi_implicit_euler']
    assert '**semi_implicit_euler on acc_spring**' in written
    assert estimates.flag(estimates.ratios(bare['semi_implicit_euler', 'acc_spring'])) == \
        estimates.UNDER


def test_flag_reads_the_worst_tick_either_way():
    """One tick beyond a factor 10 decides; round-off alone gives no verdict."""
    assert estimates.flag(np.array([1.0, 0.5, 2.0])) == estimates.GOOD
    assert estimates.flag(np.array([1.0, 0.09])) == estimates.UNDER
    assert estimates.flag(np.array([1.0, 11.0])) == estimates.OVER
    assert estimates.flag(np.array([0.0, 11.0])) == estimates.UNDER
    assert estimates.flag(np.array([])) == estimates.ROUND_OFF
