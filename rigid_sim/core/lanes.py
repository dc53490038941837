# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A block of bodies side by side: scratch rows with one lane per body, for vector code.

A kernel that takes one body at a time through a step keeps it in registers, but the state
is (N, 13) rows, so LLVM finds no loop whose iterations do the same arithmetic on adjacent
numbers and emits scalar instructions only. Held in lanes, a block of :data:`LANES` bodies
is a flat scratch array of rows, row ``r`` of lane ``j`` at ``r * LANES + j``: a loop over
the lanes reads and writes at offsets known when compiling, and LLVM turns it into vector
instructions across the bodies (docs/performance.md, "Bodies in lanes"). The loops must
call nothing that is not inlined, and nothing that may raise (a division under numba's
default error model does): what they call is compiled ``inline='always'`` and the kernels
with ``error_model='numpy'``.

A body's quantities are read and written as the tuples :mod:`~rigid_sim.core.kinematics`
uses; a state or slope (x, q, P, L) takes 13 rows.
"""
from rigid_sim.core.compiled import helper

# Bodies side by side: 8 doubles fill an AVX-512 register; 16 measured the same, 4 slower.
LANES = 8
STATE_ROWS = 13


@helper(inline='always')
def lane3(s, row, j):
    """Lane ``j`` of rows ``row`` to ``row + 2``: a 3-tuple."""
    return (s[row * LANES + j], s[(row + 1) * LANES + j], s[(row + 2) * LANES + j])


@helper(inline='always')
def lane4(s, row, j):
    """Lane ``j`` of rows ``row`` to ``row + 3``: a 4-tuple."""
    return (s[row * LANES + j], s[(row + 1) * LANES + j], s[(row + 2) * LANES + j],
            s[(row + 3) * LANES + j])


@helper(inline='always')
def lane9(s, row, j):
    """Lane ``j`` of rows ``row`` to ``row + 8``: a 9-tuple (a matrix, as kinematics has it)."""
    return (s[row * LANES + j], s[(row + 1) * LANES + j], s[(row + 2) * LANES + j],
            s[(row + 3) * LANES + j], s[(row + 4) * LANES + j], s[(row + 5) * LANES + j],
            s[(row + 6) * LANES + j], s[(row + 7) * LANES + j], s[(row + 8) * LANES + j])


@helper(inline='always')
def put(s, row, j, v):
    """Lane ``j`` of rows ``row`` to ``row + len(v) - 1`` = the tuple ``v``."""
    for k in range(len(v)):
        s[(row + k) * LANES + j] = v[k]


@helper(inline='always')
def state(s, row, j):
    """Lane ``j`` of the 13 rows from ``row``: a state or slope as (x, q, P, L) tuples."""
    return lane3(s, row, j), lane4(s, row + 3, j), lane3(s, row + 7, j), lane3(s, row + 10, j)


@helper(inline='always')
def put_state(s, row, j, v):
    """Lane ``j`` of the 13 rows from ``row`` = the (x, q, P, L) tuples ``v``."""
    put(s, row, j, v[0])
    put(s, row + 3, j, v[1])
    put(s, row + 7, j, v[2])
    put(s, row + 10, j, v[3])
