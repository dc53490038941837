# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The substep loop of every kernel that takes all bodies through each substep in turn.

A method gives its substep as a compiled function ``substep(y, k, *arguments)``: it
advances every body of ``y`` (N, 13) in place through substep ``k`` (0-based) and adds each
body's error estimate of the substep into the method's ``error`` (N,). The loop checks the
state after each: a substep that leaves a non-finite value or a quaternion off unit ends
the loop, and the step reports it (:func:`~rigid_sim.core.step_control.failure_message`).

The kernels that take one body at a time through all its substeps in registers
(``*_per_body``) loop inside the body instead, over tuples that no function boundary can
carry without taking references to every array of the scene (docs/performance.md, "A body
at a time").
"""
import math

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper


@helper(inline='always')
def substeps_checked(substep, y, count, arguments, error, estimated=True):
    """Run ``substep(y, k, *arguments)`` for ``k`` from 0 to ``count - 1``, checking ``y``.

    ``error`` (N,), which the substeps add their estimates into (it is among
    ``arguments``), is zeroed first. Returns the failure code and the largest estimate:
    (0, ``error.max()``), or the first bad substep's code, its 1-based index, negative for a
    quaternion that overflowed before it was normalised (see
    :func:`~rigid_sim.core.kinematics.check_substep`), with an infinite estimate.
    ``estimated`` False (a constant of the kernel: substeps that estimate nothing) leaves
    ``error`` as it is and returns NaN for the estimate, not estimated.
    """
    if estimated:
        error[:] = 0.0
    for k in range(count):
        substep(y, k, *arguments)
        code = kin.check_substep(y)
        if code != 0:
            return code * (k + 1), math.inf
    return 0, (error.max() if estimated else math.nan)
