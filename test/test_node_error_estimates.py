# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Error control and error estimates through the node: a thin rod spun about its middle axis.

The rod's principal moments are 1e-4, 1 and 1.0001 kg m^2 (a 12 kg box, 1 m x 1 cm x
0.1 mm); spun at omega = (0, 100, 0.1) rad/s it flips about its intermediate axis. Nothing
torques it, so its angular momentum and rotational energy are constants of the exact motion;
what the node publishes over DDS (pose and twist) gives both.
"""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import ros_tools

LENGTH, WIDTH, THICKNESS = math.sqrt(1.0 - 1e-8), math.sqrt(1e-4 - 1e-8), 1e-4   # m
MASS = 12.0   # kg: I = M/12 (b^2 + c^2, a^2 + c^2, a^2 + b^2) = (1e-4, 1, 1.0001) kg m^2
INERTIA = MASS / 12.0 * np.diag([WIDTH ** 2 + THICKNESS ** 2, LENGTH ** 2 + THICKNESS ** 2,
                                 LENGTH ** 2 + WIDTH ** 2])
ROD = f"""
bodies:
  - name: rod
    shape: {{type: box, size: [{LENGTH!r}, {WIDTH!r}, {THICKNESS!r}]}}
    mass: {MASS}
    twist: {{linear: [0.0, 0.0, 0.0], angular: [0.0, 100.0, 0.1]}}
    wrench_input: false
"""
TICKS = 500   # 5 s at the node's default 0.01 s
TOLERANCE = 1e-6


def invariants(probe):
    """Return |L| and the rotational energy from the rod's last published pose and twist."""
    _, orientation, _, angular_velocity, _ = probe.state('rod')
    turn = Rotation.from_quat(orientation).as_matrix()
    momentum = turn @ INERTIA @ turn.T @ angular_velocity
    return np.linalg.norm(momentum), 0.5 * angular_velocity @ momentum


def largest_in_windows(probe):
    """Return the largest local estimate over the /diagnostics windows heard that had a step.

    The node publishes once a second of wall time as well: the run's steps may fall into
    several windows, and the last one may have none.
    """
    key = 'error estimate: largest local in window'
    probe.diagnostics.now()
    texts = [item.value for array in probe.diagnostics.heard for item in array.status[0].values
             if item.key == key]
    assert texts and 'none (no step in window)' in texts[-1]   # values() has stepped none
    return max(float(text) for text in texts if not text.startswith('none'))


def spun(rigid_sim, **parameters):
    """Run the rod for TICKS ticks with rk4; its relative |L| and energy drift, and a probe."""
    sim = rigid_sim(yaml=ROD, integrator='rk4', tolerance=TOLERANCE, time_step=0.01,
                    **parameters)
    probe = ros_tools.Probe(sim, 'rod')
    sim.step(1)
    start = invariants(probe)
    sim.step(TICKS)
    end = invariants(probe)
    return [abs(after / before - 1.0) for before, after in zip(start, end)], sim, probe


def test_the_rod_is_the_thin_rod():
    """The box is the rod: moments 1e-4, 1, 1.0001 kg m^2 (to 1e-7)."""
    np.testing.assert_allclose(np.diag(INERTIA), [1e-4, 1.0, 1.0001], rtol=1e-7)


def test_rk4_under_error_control_keeps_the_thin_rod_within_1e_4(rigid_sim):
    """rk4, tolerance 1e-6: |L| and energy within 1e-4 after 5 s, and /diagnostics says so.

    /diagnostics shows the largest local estimate of its window within the tolerance, an
    accumulated estimate, and the drift of |L| and energy that the probe measured.
    """
    (momentum, energy), sim, probe = spun(rigid_sim)
    assert momentum < 1e-4 and energy < 1e-4
    values = probe.diagnostics.values()
    assert values['error control'] == f'on, tolerance {TOLERANCE:g}'
    assert 0.0 < largest_in_windows(probe) <= TOLERANCE
    assert float(values['error estimate: accumulated since reset']) > 0.0
    drift = float(values['error estimate: angular momentum drift of torque-free bodies'])
    assert drift == pytest.approx(momentum, rel=1e-3, abs=1e-12)
    assert float(values['error estimate: energy drift of torque-free bodies']) < 1e-4
    reading = sim.error_estimate()
    assert reading.momentum_drift == pytest.approx(drift, rel=1e-6)   # as the text rounds it
    assert int(values['substeps of the last step']) > 1


def test_without_error_control_rk4_loses_the_thin_rod(rigid_sim):
    """The same run with fixed steps: one substep, |L| or energy off by more than 1 %.

    What /diagnostics says of it is worth reading: its estimate is far above the tolerance.
    """
    (momentum, energy), sim, probe = spun(rigid_sim, error_control=False)
    assert max(momentum, energy) > 1e-2
    values = probe.diagnostics.values()
    assert values['error control'] == 'off'
    assert largest_in_windows(probe) > 100 * TOLERANCE
