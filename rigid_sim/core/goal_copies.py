# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Copies of one body as rows of one state, stepped together by the world's own kernels.

A goal solver differentiates a whole flight by finite differences: one rollout at the
unknowns and one per perturbed unknown. Stacked as rows of one (K, 13) state, they are one
compiled call of the world's integrator instead of K. Every effect's parameters are indexed
by body, so the copies get the effects' arrays taken at the copied rows and repeated. A body
that an effect couples to others (a spring between two bodies) is copied with every body it
is connected to, so each copy is the whole group. The arithmetic of a row is the world's to
the last bit: the kernels treat each body alike whatever the other rows hold.
"""
import numpy as np

from rigid_sim.core.effects.damping import DampingParameters
from rigid_sim.core.effects.gravity import GravityParameters
from rigid_sim.core.effects.springs import AnchoredSpringParameters, SpringParameters
from rigid_sim.core.inputs import WrenchInputs
from rigid_sim.core.integrators import make_integrator
from rigid_sim.core.kinematics import UNIT_QUATERNION_SLACK
from rigid_sim.core.state import Model, RigidBodies

# Row-substeps of one compiled call: the kernels hold the GIL, so a solve in a worker
# thread hands it back to the executor at least every ~2 ms.
CALL_WORK = 2000


def _taken(array, rows, copies):
    """``array[rows]`` repeated ``copies`` times along the first axis, C-contiguous."""
    return np.ascontiguousarray(np.tile(array[rows], (copies,) + (1,) * (array.ndim - 1)))


def _grouped(first, rows, copies):
    """Rows of a per-body grouped array for ``rows`` repeated, and the new (M + 1,) starts."""
    counts = first[rows + 1] - first[rows]
    picked = np.concatenate([np.arange(first[r], first[r + 1]) for r in rows])
    starts = np.concatenate(([0], np.cumsum(np.tile(counts, copies)))).astype(np.int64)
    return np.tile(picked.astype(np.int64), copies), starts


def _anchored(p, rows, copies):
    picked, starts = _grouped(p.first, rows, copies)
    return AnchoredSpringParameters(starts, np.ascontiguousarray(p.rows[picked]))


def _springs(p, rows, copies):
    """Springs between the copied bodies, re-indexed into each copy's rows."""
    position = np.full(max(p.body.max(initial=0), p.other.max(initial=0)) + 1, -1)
    position[rows] = np.arange(rows.size)
    kept = np.flatnonzero(position[p.body] >= 0)
    shift = (rows.size * np.arange(copies))[:, None]
    other = p.other[kept]
    ends = np.where(other >= 0, position[np.maximum(other, 0)], -1)
    return SpringParameters(
        (position[p.body[kept]] + shift).ravel().astype(np.int64),
        _taken(p.lever, kept, copies), _taken(p.stiffness, kept, copies),
        _taken(p.damping, kept, copies), _taken(p.rest, kept, copies),
        np.where(ends >= 0, ends + shift, -1).ravel().astype(np.int64),
        _taken(p.other_lever, kept, copies), _taken(p.anchor, kept, copies))


def _wrenches(p, rows, copies):
    picked, starts = _grouped(p.point_start, rows, copies)
    return WrenchInputs(_taken(p.world_sum, rows, copies), _taken(p.body_sum, rows, copies),
                        _taken(p.body_held, rows, copies), starts,
                        np.ascontiguousarray(p.point_lever[picked].reshape(-1, 3)),
                        np.ascontiguousarray(p.point_force[picked].reshape(-1, 3)))


# Parameters class -> its copies: f(parameters, rows (R,) int, copies) -> parameters of
# R * copies bodies, copy k's rows at k R to (k + 1) R - 1.
COPIERS = {GravityParameters: lambda p, rows, copies: GravityParameters(
               _taken(p.weight, rows, copies)),
           DampingParameters: lambda p, rows, copies: p,
           AnchoredSpringParameters: _anchored, SpringParameters: _springs,
           WrenchInputs: _wrenches}


def coupled_group(world, index):
    """Sorted (R,) int64 rows of body ``index`` and every body a coupling effect ties it to."""
    group = {index}
    for parameters in world.effect_parameters():
        if isinstance(parameters, SpringParameters):
            links = [(a, b) for a, b in zip(parameters.body, parameters.other) if b >= 0]
            grown = True
            while grown:
                before = len(group)
                group |= {b for a, b in links if a in group}
                group |= {a for a, b in links if b in group}
                grown = len(group) > before
    return np.array(sorted(group), dtype=np.int64)


class Copies:
    """``copies`` copies of a body's group as rows ``k R .. k R + R - 1`` of one state.

    Quacks as the system an integrator is built for (``bodies``, ``effect_parameters()``,
    ``velocity_dependent``), so the world's integrator class steps it with the world's own
    compiled kernel; nothing of the world is changed.

    Parameters
    ----------
    world : rigid_sim.core.world.World
    index : int
        The body whose group is copied.
    copies : int
    """

    def __init__(self, world, index, copies):
        for parameters in world.effect_parameters():
            if type(parameters) not in COPIERS:
                raise ValueError(f'the goal solver cannot copy {type(parameters).__name__}')
        self.rows = coupled_group(world, index)
        self.width = self.rows.size
        self.target = int(np.flatnonzero(self.rows == index)[0])
        self.copies = copies
        tiled = np.tile(self.rows, copies)
        source = world.bodies
        self.bodies = RigidBodies(
            tuple(f'{source.names[i]}.{k}' for k in range(copies) for i in self.rows),
            source.mass[tiled], source.inertia_body[tiled], source.com_in_body[tiled])
        # The very numbers of the world's model (its principal axes come from one eigh).
        self.bodies.__dict__['model'] = Model(*(_taken(a, self.rows, copies)
                                                for a in source.model))
        self._effects = tuple(COPIERS[type(p)](p, self.rows, copies)
                              for p in world.effect_parameters()[:-1])
        # WrenchInputs of the copies, set by the caller per segment; the world's until then,
        # so that the integrator picks the kernel a body at a time where the world does.
        self.inputs = self.copy_inputs(world.inputs.parameters)
        self.velocity_dependent = world.velocity_dependent
        self.integrator = make_integrator(world.integrator.name, self,
                                          world.integrator.tolerance)

    def copy_inputs(self, parameters):
        """Return the copies' :class:`WrenchInputs` from a world's ``parameters``, new arrays."""
        return _wrenches(parameters, self.rows, self.copies)

    def effect_parameters(self):
        """Return the copied effects' parameters, then the copies' inputs."""
        return self._effects + (self.inputs,)

    def target_rows(self):
        """Return the row of the goal's body in each copy, (copies,) int."""
        return self.target + self.width * np.arange(self.copies)

    def begin(self, parking):
        """Start a new flight: nothing is carried from the last one; ``parking`` unused.

        (A failed row is NaN from then on; the kernels step each row alone.)
        """

    def advance(self, y, time, steps, dt, substeps):
        """Advance ``y`` in place by ``steps`` steps of ``dt``, ``substeps`` pieces each.

        In calls of about :data:`CALL_WORK` row-substeps (see there). A row that failed
        is NaN from then on.
        """
        per_call = max(1, CALL_WORK // (substeps * y.shape[0]))
        done = 0
        while done < steps:
            chunk = min(per_call, steps - done)
            if self.integrator.advance(y, time + done * dt, chunk * dt, chunk * substeps,
                                       self.effect_parameters()):
                spoiled(y)
            done += chunk


def spoiled(y):
    """Set to NaN the rows of ``y`` (K, 13) that met a non-finite value or lost their unit q."""
    with np.errstate(all='ignore'):   # the rows it looks for may hold inf and NaN
        bad = ~np.isfinite(y).all(axis=1)
        bad |= np.abs(np.einsum('ij,ij->i', y[:, 3:7], y[:, 3:7]) - 1.0) > UNIT_QUATERNION_SLACK
    y[bad] = np.nan
