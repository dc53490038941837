# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""``rk4`` for many bodies: blocks of bodies side by side, in vector instructions.

The per-body kernel of :mod:`~rigid_sim.core.integrators.runge_kutta` takes one body at a
time through a step in registers, in scalar instructions. Here ``LANES`` (8) bodies at a
time go through all their substeps and stages side by side in a scratch of rows
(:mod:`~rigid_sim.core.lanes`), so LLVM vectorises the stages' arithmetic across them; only
the wrench (any effect's code), the checks and the copies in and out go a body at a time.
Each lane does the arithmetic the per-body kernel does for its body, in the same order, so
the two agree to the last bit (test_lanes).

It pays from ``LANES_MIN`` bodies on, and compiles for several seconds more than the
per-body kernel (docs/performance.md, "Bodies in lanes"): the integrator imports this module
and compiles its kernel only for a scene that large, so a small one compiles what it did
without it. ``rk4`` only (body-axes momenta): ``rk4_world`` and ``euler`` keep the per-body
kernel.

A loop over the lanes vectorises only if it calls nothing and nothing in it may raise.
So each such loop is in a helper compiled with numba's 'numpy' error model (a division by
zero gives an infinity or NaN, which the substep's check reports as a non-finite state,
instead of a branch to raise ZeroDivisionError, which LLVM cannot vectorise), and calls
:func:`~rigid_sim.core.compiled.inlined` copies of the helpers the per-body kernel calls,
which themselves stay calls there (numba's inlining is what compiles slowly). These helpers
take only the scratch and numbers: they are compiled once and shared by both kernels and
every scene's effects, whose own code is in the kernel.
"""
import math

import numpy as np

from rigid_sim.core import kinematics, lanes
from rigid_sim.core.compiled import helper, inlined, inlined_module, kernel
from rigid_sim.core.effects.base import body_wrench
from rigid_sim.core.error_estimate import body_scales, scaled_size, turning_part
from rigid_sim.core.integrators import runge_kutta as rk
from rigid_sim.core.integrators.internal_state import derivative
from rigid_sim.core.lanes import LANES

# The helpers LLVM left as calls in the lanes' loops, or that divide: inlined copies
# (``matrix``, ``multiply`` and ``normalize`` also where ``derivative`` calls them).
_kin = inlined_module(kinematics, 'matrix', 'multiply', 'normalize')
_derivative = inlined(derivative, kin=_kin)
_scaled_size = inlined(scaled_size)
_turning_part = inlined(turning_part)
_step_rate = inlined(rk._step_rate, squared_part_rates=inlined(
    rk.squared_part_rates, _squared_ratio=inlined(rk._squared_ratio)))

# Rows of the scratch: states and slopes 13 rows each. The step's sum, its start, the slope
# at hand, the stage, the estimate's terms; force and torque, world L at the step's end,
# the error scales, the rate, the estimate's total; I^-1 and 1 / M.
_SUM, _START, _SLOPE, _STAGE, _ESTIMATE = 0, 13, 26, 39, 52
_WRENCH, _WORLD_L, _SCALES, _RATE, _TOTAL = 65, 71, 74, 77, 78
_INERTIA, _INVERSE_MASS, _ROWS = 79, 88, 89


@helper(inline='always')
def _runge_kutta_in_lanes(y, first_body, end, model, effects, time, h, substeps, method,
                          estimated, error, fsal, continuing):
    """Step bodies ``first_body`` to ``end - 1`` as the per-body kernel does, in lanes.

    Arguments and result those of :func:`~rigid_sim.core.integrators.runge_kutta.
    _runge_kutta_per_body` (body axes). A block at the end with fewer bodies fills its
    other lanes with its last body, never stored. A body that fails a substep stops there:
    the failure code of the earliest bad substep over the bodies (the first such body's
    sign) is returned. The effects' wrench is evaluated here, inlined, a body at a time: a
    call would take and drop references to every array of ``effects`` for every body
    (docs/performance.md, "A body at a time"); the lanes' parts are calls once a stage.
    """
    a, b, c, e, e_end, rate_weight = method
    over_a21 = 1.0 / a[1] if b.size > 1 else 0.0   # for the rate: once, not for every body
    if not continuing:
        rk._start_slopes_per_body(y, first_body, end, model, effects, time, True, fsal)
    first, largest = 0, (0.0 if estimated else math.nan)
    s = np.empty(_ROWS * LANES)
    for base in range(first_body, end, LANES):
        count = min(LANES, end - base)
        _gather_lanes(s, y, fsal, model, base, count, h * substeps, estimated)
        alive = (1 << count) - 1   # a bit for each lane whose body has not failed
        for k in range(substeps):
            _first_stage_lanes(s, h * b[0], h * e[0] if estimated else 0.0)
            for stage in range(1, b.size + 1):
                if stage < b.size:
                    _stage_lanes(s, a[stage] * h)
                    at = time + k * h + c[stage] * h
                else:   # the end, as the next substep starts from it
                    _end_lanes(s)
                    at = time + (k + 1) * h
                for j in range(LANES):   # a body at a time: the effects' code is any
                    x, q, p, angular = lanes.state(s, _STAGE, j)
                    # Turned here, the world L costs nothing where no effect reads it.
                    if stage == b.size:
                        big_l = lanes.lane3(s, _WORLD_L, j)
                    else:
                        big_l = kinematics.rotate(kinematics.matrix(q), angular)
                    force, torque = body_wrench(effects, base + min(j, count - 1), x, q, p,
                                                big_l, at, model)
                    lanes.put3(s, _WRENCH, j, force)
                    lanes.put3(s, _WRENCH + 3, j, torque)
                _slope_lanes(s, over_a21 if estimated and stage == 1 and stage < b.size
                             else 0.0)
                if stage < b.size:
                    _add_slope_lanes(s, _SUM, h * b[stage])
                    if estimated and e[stage] != 0.0:
                        _add_slope_lanes(s, _ESTIMATE, h * e[stage])
            if estimated:
                _close_estimate_lanes(s, h * e_end, rate_weight)
            first, alive = _check_lanes(s, y, fsal, base, count, k, first, alive)
        largest = _store_lanes(s, y, fsal, error, base, count, alive, estimated, largest)
    return first, largest


@helper
def _gather_lanes(s, y, fsal, model, base, count, dt, estimated):
    """Bodies ``base`` on into the lanes: state (internal layout), first slope, scales, inertia.

    Lanes past ``count`` take the last body's. ``dt`` is the step the scales are for.
    """
    for j in range(LANES):
        i = base + min(j, count - 1)
        x, q, p, big_l = kinematics.body_state(y, i)
        angular = kinematics.rotate_inverse(kinematics.matrix(q), big_l)
        lanes.put_state(s, _SUM, j, (x, q, p, angular))
        lanes.put3(s, _WORLD_L, j, big_l)
        lanes.put_state(s, _SLOPE, j, kinematics.body_state(fsal, i))
        lanes.put_matrix(s, _INERTIA, j, kinematics.entries(model.inertia_inv, i))
        s[_INVERSE_MASS * LANES + j] = model.inverse_mass[i]
        if estimated:
            lanes.put3(s, _SCALES, j, body_scales(model, i, p, big_l, dt))
            s[_TOTAL * LANES + j] = 0.0


@helper(error_model='numpy')
def _first_stage_lanes(s, weight, estimate_weight):
    """Start a substep: the sums at the state plus ``weight`` times the first slope.

    The estimate's terms start at ``estimate_weight`` times it (none when 0), the rate at 0.
    """
    for j in range(LANES):
        start = lanes.state(s, _SUM, j)
        lanes.put_state(s, _START, j, start)
        lanes.put_state(s, _SUM, j, rk._plus_slope(start, weight, lanes.state(s, _SLOPE, j)))
        lanes.put_state(s, _ESTIMATE, j, rk._NO_SLOPE)
        s[_RATE * LANES + j] = 0.0
    if estimate_weight != 0.0:
        _add_slope_lanes(s, _ESTIMATE, estimate_weight)


@helper(error_model='numpy')
def _stage_lanes(s, step):
    """Put the stage ``start + step slope`` into the stage's rows."""
    for j in range(LANES):
        lanes.put_state(s, _STAGE, j, rk._plus_slope(lanes.state(s, _START, j), step,
                                                     lanes.state(s, _SLOPE, j)))


@helper(error_model='numpy')
def _end_lanes(s):
    """Make the step's end as its last evaluation sees it: ``q`` normalised, ``L`` turned.

    The internal momentum the next substep starts from is the one turned there and back.
    """
    for j in range(LANES):
        x, q, p, angular = lanes.state(s, _SUM, j)
        q = _kin.normalize(q)
        r = _kin.matrix(q)
        big_l = kinematics.rotate(r, angular)
        angular = kinematics.rotate_inverse(r, big_l)
        lanes.put_state(s, _SUM, j, (x, q, p, angular))
        lanes.put_state(s, _STAGE, j, (x, q, p, angular))
        lanes.put3(s, _WORLD_L, j, big_l)


@helper(error_model='numpy')
def _slope_lanes(s, over_a21):
    """Each lane's slope at its stage and wrench; ``over_a21`` not 0: the rate from them.

    The rate compares the new slope with the one it replaces, the first.
    """
    if over_a21 == 0.0:
        for j in range(LANES):
            lanes.put_state(s, _SLOPE, j, _lane_slope(s, j))
        return
    for j in range(LANES):
        slope = _lane_slope(s, j)
        s[_RATE * LANES + j] = _step_rate(lanes.state(s, _SLOPE, j), slope, over_a21)
        lanes.put_state(s, _SLOPE, j, slope)


@helper(inline='always')
def _lane_slope(s, j):
    """:func:`~rigid_sim.core.integrators.internal_state.derivative` of lane ``j``."""
    _, q, p, angular = lanes.state(s, _STAGE, j)
    return _derivative(q, p, angular, lanes.lane3(s, _WRENCH, j),
                       lanes.lane3(s, _WRENCH + 3, j), lanes.matrix(s, _INERTIA, j),
                       s[_INVERSE_MASS * LANES + j], True)


# Inlined where it is called, with ``row`` a constant there: as a helper of its own, the row
# an argument, LLVM cannot tell the rows it writes from the slope's it reads, and the loop
# stayed scalar.
@helper(inline='always')
def _add_slope_lanes(s, row, weight):
    """Add ``weight`` times the slope at hand to the 13 rows from ``row``."""
    for j in range(LANES):
        lanes.put_state(s, row, j, rk._plus_slope(lanes.state(s, row, j), weight,
                                                  lanes.state(s, _SLOPE, j)))


@helper(error_model='numpy')
def _close_estimate_lanes(s, weight, rate_weight):
    """Add each lane's estimate of the substep, its terms plus ``weight`` times the end slope."""
    for j in range(LANES):
        dx, dq, dp, dl = rk._plus_slope(lanes.state(s, _ESTIMATE, j), weight,
                                        lanes.state(s, _SLOPE, j))
        s[_TOTAL * LANES + j] += rk._own_error(
            _scaled_size(dx, _turning_part(dq, lanes.state(s, _SUM, j)[1]), dp, dl,
                         lanes.lane3(s, _SCALES, j)), rate_weight, s[_RATE * LANES + j])


@helper
def _check_lanes(s, y, fsal, base, count, k, first, alive):
    """Check each living lane after substep ``k``; return the failure code and the living.

    A body that fails stops there: its state and slope are stored, its estimate is infinite.
    """
    for j in range(count):
        if not alive & (1 << j):
            continue
        x, q, p, _ = lanes.state(s, _SUM, j)
        big_l = lanes.lane3(s, _WORLD_L, j)
        code = kinematics.check_body(x, q, p, big_l)
        if code != 0:
            first = kinematics.earlier_failure(first, code, k + 1)
            kinematics.store_body(y, base + j, x, q, p, big_l)
            kinematics.store_body(fsal, base + j, *lanes.state(s, _SLOPE, j))
            alive &= ~(1 << j)
    return first, alive


@helper
def _store_lanes(s, y, fsal, error, base, count, alive, estimated, largest):
    """Store the living lanes' states and end slopes, every lane's estimate; the largest."""
    for j in range(count):
        living = alive & (1 << j)
        if living:
            x, q, p, _ = lanes.state(s, _SUM, j)
            kinematics.store_body(y, base + j, x, q, p, lanes.lane3(s, _WORLD_L, j))
            kinematics.store_body(fsal, base + j, *lanes.state(s, _SLOPE, j))
        if estimated:
            total = s[_TOTAL * LANES + j] if living else math.inf
            error[base + j] = total
            largest = max(largest, total)
    return largest


# One kernel per estimate, as for the per-body kernels. Each steps the bodies ``work[0]`` to
# ``work[1] - 1``, with or without threads (one call is given the whole range): one kernel
# to compile for both, at 40 ns a call for releasing the interpreter lock, nothing beside
# the bodies it takes.


@kernel(nogil=True)
def runge_kutta_in_lanes(y, work, model, effects, time, h, substeps, method, error, fsal,
                         continuing):
    """:func:`_runge_kutta_in_lanes` of bodies ``work[0]`` to ``work[1] - 1``."""
    return _runge_kutta_in_lanes(y, work[0], work[1], model, effects, time, h, substeps,
                                 method, True, error, fsal, continuing)


@kernel(nogil=True)
def runge_kutta_in_lanes_unestimated(y, work, model, effects, time, h, substeps, method, error,
                                     fsal, continuing):
    """:func:`_runge_kutta_in_lanes` of bodies ``work[0]`` to ``work[1] - 1``, no estimate."""
    return _runge_kutta_in_lanes(y, work[0], work[1], model, effects, time, h, substeps,
                                 method, False, error, fsal, continuing)


# estimated -> kernel
KERNELS = {True: runge_kutta_in_lanes, False: runge_kutta_in_lanes_unestimated}
