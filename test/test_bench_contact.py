# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench contact --quick``: it runs, writes its section, slides and bounces right."""
from rigid_sim.bench import cli


def test_quick_contact_bench_writes_its_section(tmp_path):
    """The section names MuJoCo's version; rigid_sim's 45 degree slide stops at v0^2/(2 mu g).

    The bounce's apexes are ``e^(2k) h0``: to 1e-6 in exact mode; in velocity mode within
    what the penetration of a step adds, ``v dt`` over the apex (2 % at the fourth, 1 ms).
    """
    out = tmp_path / 'contact.md'
    args = cli.build_parser().parse_args(['contact', '--quick', '--out', str(out),
                                          '--plot', str(tmp_path / 'contact.png')])
    results = args.run(args)
    text = out.read_text()
    assert '<!-- rigid_sim_bench contact: begin -->' in text and 'MuJoCo 4.0.1' in text
    assert abs(results['slide']['rigid_sim']) < 0.005
    assert (tmp_path / 'contact.png').stat().st_size > 0
    drift, overlap, _ = results['stack']['rigid_sim']
    assert drift < 1e-4 and overlap < 1e-3
    velocity, exact = (results['bounce'][f'rigid_sim, mode {mode}'][0]
                       for mode in ('velocity', 'exact'))
    assert abs(exact) < 1e-6 and abs(velocity) < 0.03
