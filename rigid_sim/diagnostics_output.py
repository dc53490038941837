# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's /diagnostics: one status about once a second, over one window of ticks."""
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.clock import Clock, ClockType

from rigid_sim import conversions
from rigid_sim.core.step_control import ErrorReason
from rigid_sim.diagnostics_window import TickStats, health, refusal_values, window_values
from rigid_sim.qos_overrides import QUEUE_DEPTH

PERIOD = 1.0  # s of wall time; /diagnostics aggregators expect about 1 Hz


class DiagnosticsOutput:
    """Publishes the health of the simulation and collects the tick times between two.

    Parameters
    ----------
    node : rigid_sim.node.RigidSimNode
        Owns the publisher (created through its ``qos_overrides``); its name is the status
        name.
    publish : callable
        Called without arguments once per ``PERIOD``: the node's report, which calls
        :meth:`publish`.
    sim_time : float
        Simulated time when the first window starts, s.
    """

    def __init__(self, node, publish, sim_time):
        self._node = node
        self._publisher = node.qos_overrides.create_publisher(DiagnosticArray, '/diagnostics',
                                                              QUEUE_DEPTH)
        self.stats = TickStats(sim_time)
        node.create_timer(PERIOD, publish, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def restart(self, sim_time):
        """Start a new window at ``sim_time`` (after a reset or a new scene)."""
        self.stats = TickStats(sim_time)

    def publish(self, world, settings, paused, refusals, dropped, since_tick=None, extra=()):
        """Publish the window's status and start a new window.

        Parameters
        ----------
        world : rigid_sim.core.world.World
            The world whose time, energy and safeguard counts are reported.
        settings : rigid_sim.parameters.Settings
            The node's settings (integrator, rate, time step).
        paused : bool
            Whether integration is paused.
        refusals : rigid_sim.inputs.Refusals
            Refused inputs per body and the last reason.
        dropped : int
            Ticks given up behind wall time in the window.
        since_tick : float or None
            s of wall time since the latest tick, where ticks are due on the wall clock.
        extra : dict
            Further values to report (the reconfiguration's).
        """
        target = settings.real_time_factor
        values = {'simulated time [s]': world.time, 'paused': paused,
                  'integrator': settings.integrator,
                  **window_values(self.stats, world,
                                  'none (rate 0: as fast as possible)' if target is None
                                  else target),
                  'ticks dropped behind wall time': dropped,
                  **refusal_values(refusals.counts, refusals.last, refusals.superseded),
                  **dict(extra)}
        period = 1.0 / settings.rate if settings.rate > 0.0 else None
        level, summary = capped_work(world.diagnostics, self.stats.failed_ticks,
                                     *health(self.stats, period, dropped, since_tick))
        if paused and level == DiagnosticStatus.OK:
            summary = 'paused'   # integration is not running; the ticks that publish are
        self._publisher.publish(conversions.diagnostics(
            f'{self._node.get_name()}: physics', world.time, level, summary, values))
        self.restart(world.time)


def capped_work(safeguards, failed_ticks, level, summary):
    """Return the window's ``level`` and ``summary``, raised where a work cap held a step.

    Error control held to its cap on work (``ERROR_WORK``) keeps an estimate above the
    tolerance, maybe by orders of magnitude: a WARN with the numbers, not "running". A step
    given up at its method's cap on internal steps is said to be that, not a non-finite one.
    """
    why = safeguards.why
    if isinstance(why, ErrorReason) and why.capped and level < DiagnosticStatus.WARN:
        return DiagnosticStatus.WARN, (
            f'error control capped: estimate {safeguards.error_estimate:.3g} against '
            f'tolerance {why.tolerance:.3g} at {why.substeps} {why.method} substeps, the most '
            'a step may take (ERROR_WORK); a larger tolerance or fewer bodies meets it')
    if (level == DiagnosticStatus.ERROR and failed_ticks
            and 'capped' in safeguards.last_failure):
        return level, (f'{failed_ticks} ticks stopped at a step given up, state kept: '
                       f'{safeguards.last_failure}')
    return level, summary
