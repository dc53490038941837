# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""What the node reports on /diagnostics: one window of ticks, the world's health, a level.

Kept apart from the node so that the node only wires topics and timers; nothing here talks
to ROS except the level constants of ``diagnostic_msgs``.
"""
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus

from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, POSITION


class TickStats:
    """Step times and advanced simulated time over one diagnostics window."""

    def __init__(self, sim_time):
        self.ticks = 0
        self.step_total = 0.0   # s of wall time spent applying inputs and integrating
        self.step_max = 0.0     # s, the longest of them
        self.failed_ticks = 0   # ticks cut short by a step the world gave up
        self.largest_error = 0.0   # the largest local error estimate of the window's steps
        self.steps = 0             # steps taken in the window (a paused tick takes none)
        self.sim_start = sim_time
        self.wall_start = time.monotonic()

    def add(self, step_seconds):
        self.ticks += 1
        self.step_total += step_seconds
        self.step_max = max(self.step_max, step_seconds)

    def note_error(self, estimate):
        """Take a step's local error estimate into the window's largest."""
        self.largest_error = max(self.largest_error, estimate)
        self.steps += 1

    @property
    def step_mean(self):
        """Mean wall seconds per tick spent applying inputs and integrating."""
        return self.step_total / max(self.ticks, 1)

    def real_time_factor(self, sim_time):
        """Return the simulated seconds advanced per wall second since the window began."""
        return (sim_time - self.sim_start) / max(time.monotonic() - self.wall_start, 1e-9)


def window_values(stats, world, target_real_time_factor):
    """Key -> value of the window's timing and the world's state and safeguards."""
    y, safeguards = world.y, world.diagnostics
    return {
        'step time mean [s]': stats.step_mean, 'step time max [s]': stats.step_max,
        'real-time factor': stats.real_time_factor(world.time),
        'real-time factor target': target_real_time_factor,
        'energy [J]': world.energy(),
        'linear momentum [kg m/s]': y[:, LINEAR_MOMENTUM].sum(axis=0),
        'angular momentum about the world origin [kg m^2/s]': (
            y[:, ANGULAR_MOMENTUM] + np.cross(y[:, POSITION], y[:, LINEAR_MOMENTUM])
        ).sum(axis=0),
        'substeps of the last step': safeguards.substeps,
        'why the last step was split': safeguards.reason,
        'rejected steps': safeguards.rejected_steps,
        'failed steps': safeguards.failed_steps,
        'last step failure': safeguards.last_failure,
        **error_values(stats, world)}


def error_values(stats, world):
    """Key -> value of the integration's error estimates (README: error estimates)."""
    control = world.control
    momentum, energy = world.invariant_drift()
    return {
        'error estimate: largest local in window': (
            stats.largest_error if stats.steps else 'none (no step in window)'),
        'error estimate: accumulated since reset': world.diagnostics.accumulated_error,
        'error estimate: angular momentum drift of torque-free bodies': (
            'none (every body torqued)' if np.isnan(momentum) else momentum),
        'error estimate: energy drift of torque-free bodies': (
            'none (every body torqued)' if np.isnan(energy) else energy),
        'error control': (f'on, tolerance {control.tolerance:g}' if control.error_control
                          else 'off')}


def refusal_values(refused, last_refusal, superseded):
    """Return the key -> value of refused and superseded inputs.

    Refused: the total, per body that had any (a scene may have 10 000 bodies), and the
    last reason; superseded by a newer message before a tick: the total.
    """
    return {'refused inputs': sum(refused.values()),
            **{f'refused inputs {name}': count for name, count in refused.items() if count},
            'last refused input': last_refusal,
            'superseded inputs': sum(superseded.values())}


# A tick this many periods late means the loop has stopped, not merely jittered.
STALL_PERIODS = 2.0


def health(stats, tick_period, dropped=0, since_tick=None):
    """Grade the window that ``stats`` covers: a diagnostic level and a summary.

    Parameters
    ----------
    stats : TickStats
        Step times, failed ticks and advanced simulated time over the window.
    tick_period : float or None
        s of wall time per tick; None when the node ticks as fast as it can.
    dropped : int
        Ticks given up in the window because the simulation fell behind wall time.
    since_tick : float or None
        s of wall time since the latest tick; None where no tick is due (paused at rate 0,
        or ticked by the caller).
    """
    if (tick_period is not None and since_tick is not None
            and since_tick > STALL_PERIODS * tick_period):
        return DiagnosticStatus.ERROR, (f'no tick for {since_tick:.3g} s, one is due every '
                                        f'{tick_period:.3g} s')
    if stats.failed_ticks:
        return DiagnosticStatus.ERROR, (f'{stats.failed_ticks} ticks stopped at a step that '
                                        f'stayed non-finite; state kept')
    if dropped:
        return DiagnosticStatus.WARN, (f'fell behind wall time: {dropped} ticks given up, '
                                       'simulated time runs slower than the rate')
    if tick_period is not None and stats.step_mean > tick_period:
        return DiagnosticStatus.WARN, 'steps take longer than a tick'
    return DiagnosticStatus.OK, 'running'
