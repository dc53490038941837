# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rigid_sim_bench imu`` runs end to end on its quick configuration and reports a row per N."""
import yaml

from rigid_sim.bench import cli
from rigid_sim.bench.imu_cost import BODIES, SECTION, VARIANTS, imu_scene
from rigid_sim.core.scene import parse_scene


def test_variants_put_an_imu_on_every_body_or_on_none():
    for variant, imu in VARIANTS.items():
        scene = parse_scene(yaml.safe_load(imu_scene(3, imu)))
        assert [len(body.imus) for body in scene.bodies] == [int(imu is not None)] * 3
    noisy, = parse_scene(yaml.safe_load(imu_scene(1, VARIANTS['noisy']))).bodies[0].imus
    assert noisy.gyro.stddev > 0 and noisy.accel.dynamic_bias_stddev > 0


def test_quick_imu_benchmark_reports_every_n(tmp_path, capsys):
    """Every N gets a row with positive tick times in each variant; --out writes the section."""
    out = tmp_path / 'performance.md'
    assert cli.main(['imu', '--quick', '--out', str(out)]) == 0
    text = capsys.readouterr().out
    rows = [line for line in text.splitlines() if line.startswith('| ') and '---' not in line]
    assert [row.split('|')[1].strip() for row in rows[1:]] == [str(n) for n in BODIES]
    for row in rows[1:]:
        ticks = [float(cell) for cell in row.split('|')[2:5]]
        assert all(tick > 0 for tick in ticks)
    assert f'<!-- {SECTION}: begin -->' in out.read_text()
