# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The simulator node as the test kit runs it."""
from rigid_sim.node import RigidSimNode


class SteppedNode(RigidSimNode):
    """The simulator as the kit runs it: it ticks only when :meth:`Simulation.step` says."""

    def _describe(self, paused):
        # The node's own line states a wall rate and a real-time factor; here no wall clock
        # runs, so the line says what does.
        s = self.settings
        return (f'simulating {self.world.bodies.count} bodies from {self.scene.path} with '
                f'{s.integrator}, no wall clock: the test kit ticks it in step() only, '
                f'time_step {s.time_step:g} s x {s.substeps} substeps; publishing every '
                f'{s.publish_every} ticks; topics under {self.get_fully_qualified_name()}/'
                f'{", paused" if paused else ""}')
