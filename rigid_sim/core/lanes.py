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
default error model does): :mod:`~rigid_sim.core.integrators.rk4_lanes` says how.

A body's quantities are read and written as the tuples :mod:`~rigid_sim.core.kinematics`
uses; a state or slope (x, q, P, L) takes 13 rows. Each accessor is written out, element by
element: numba types every inlined call again, and a loop over a tuple's items compiles to
a switch on the index.
"""
from rigid_sim.core.compiled import helper

# Bodies side by side: 8 doubles fill an AVX-512 register; 16 measured the same, 4 slower.
LANES = 8
# Bodies from which ``rk4`` steps them in lanes: 19 % faster a step there, 6-12 % with 8 to
# 16 bodies, too little to pay the kernel's few seconds of compiling at a cold start
# (docs/performance.md, "Bodies in lanes").
LANES_MIN = 32


@helper(inline='always')
def lane3(s, row, j):
    """Lane ``j`` of rows ``row`` to ``row + 2``: a 3-tuple."""
    at = row * LANES + j
    return (s[at], s[at + LANES], s[at + 2 * LANES])


@helper(inline='always')
def put3(s, row, j, v):
    """Lane ``j`` of rows ``row`` to ``row + 2`` = the 3-tuple ``v``."""
    at = row * LANES + j
    s[at], s[at + LANES], s[at + 2 * LANES] = v


@helper(inline='always')
def state(s, row, j):
    """Lane ``j`` of the 13 rows from ``row``: a state or slope as (x, q, P, L) tuples."""
    at = row * LANES + j
    return ((s[at], s[at + LANES], s[at + 2 * LANES]),
            (s[at + 3 * LANES], s[at + 4 * LANES], s[at + 5 * LANES], s[at + 6 * LANES]),
            (s[at + 7 * LANES], s[at + 8 * LANES], s[at + 9 * LANES]),
            (s[at + 10 * LANES], s[at + 11 * LANES], s[at + 12 * LANES]))


@helper(inline='always')
def put_state(s, row, j, v):
    """Lane ``j`` of the 13 rows from ``row`` = the (x, q, P, L) tuples ``v``."""
    at = row * LANES + j
    s[at], s[at + LANES], s[at + 2 * LANES] = v[0]
    s[at + 3 * LANES], s[at + 4 * LANES], s[at + 5 * LANES], s[at + 6 * LANES] = v[1]
    s[at + 7 * LANES], s[at + 8 * LANES], s[at + 9 * LANES] = v[2]
    s[at + 10 * LANES], s[at + 11 * LANES], s[at + 12 * LANES] = v[3]


@helper(inline='always')
def matrix(s, row, j):
    """Lane ``j`` of rows ``row`` to ``row + 8``: a 9-tuple (a matrix, as kinematics has it)."""
    at = row * LANES + j
    return (s[at], s[at + LANES], s[at + 2 * LANES], s[at + 3 * LANES], s[at + 4 * LANES],
            s[at + 5 * LANES], s[at + 6 * LANES], s[at + 7 * LANES], s[at + 8 * LANES])


@helper(inline='always')
def put_matrix(s, row, j, m):
    """Lane ``j`` of rows ``row`` to ``row + 8`` = the 9-tuple ``m``."""
    at = row * LANES + j
    (s[at], s[at + LANES], s[at + 2 * LANES], s[at + 3 * LANES], s[at + 4 * LANES],
     s[at + 5 * LANES], s[at + 6 * LANES], s[at + 7 * LANES], s[at + 8 * LANES]) = m
