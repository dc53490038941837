# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench flood`` runs end to end on its quick configuration."""
import math

from rigid_sim.bench import cli


def test_quick_flood_measures_both_windows_and_counts_what_was_superseded(tmp_path):
    """Check the flood reaches the node and both windows give a real-time factor.

    The node takes messages and supersedes all but the newest per tick; the section is
    written after the hand-written text.
    """
    out = tmp_path / 'performance.md'
    out.write_text('# Hand-written title\n')
    args = cli.build_parser().parse_args(['flood', '--quick', '--out', str(out)])
    results = args.run(args)
    (off_rtf, off_taken, off_sent), = results['off']
    (on_rtf, on_taken, on_sent), = results['on']
    assert off_sent == 0 and off_taken == 0 and on_sent > 0 and on_taken > 0
    assert math.isfinite(off_rtf) and math.isfinite(on_rtf) and on_rtf > 0
    text = out.read_text()
    assert text.startswith('# Hand-written title') and 'rigid_sim_bench flood' in text
    assert 'superseded' in text
