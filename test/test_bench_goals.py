# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench goals`` runs end to end on its quick configuration."""
from rigid_sim.bench import cli
from rigid_sim.bench.goals import DEFAULT_CASES, PLOT_NAME, QUICK, SECTION


def test_quick_goals_benchmark_solves_every_case_both_ways(tmp_path, capsys):
    """A row per case and method; both solve every reachable target; section and plot."""
    out = tmp_path / 'goals.md'
    assert cli.main(['goals', '--quick', '--out', str(out)]) == 0
    rows = [line.split('|')[1:-1] for line in capsys.readouterr().out.splitlines()
            if line.startswith('| ') and '---' not in line][1:]
    assert [(row[0].strip(), row[1].strip()) for row in rows] == [
        (case, method) for case in DEFAULT_CASES for method in ('GoalSolver', 'least_squares')]
    for row in rows:
        assert int(row[2]) == QUICK
        assert 0 <= int(row[3]) <= QUICK   # nearest: of the solved
        assert float(row[4]) >= 1.0   # the worst ratio of distances starts at the known one
        assert float(row[6]) <= 1e-9   # the worst solved target's final error, m or rad
    assert f'<!-- {SECTION}: begin -->' in out.read_text()
    assert (tmp_path / PLOT_NAME).read_bytes()[:4] == b'\x89PNG'
