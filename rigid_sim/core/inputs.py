# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Inputs of a world: wrenches applied from outside, held until replaced or timed out.

They come from users (commands), not from the scene, so they are not an effect: the world
always has them (``world.inputs``).

Each held wrench has a body, a key (the ROS frame_id it came with: a new wrench with the
same body and key replaces it) and one of four ways to act:

``world``  world axes, at the centre of mass;
``body``   body axes, at the centre of mass;
``point``  body axes, at a point given in body-frame coordinates;
``world_point``  world axes, at a point given in body-frame coordinates (a force that
keeps its direction while the body turns under it).

A body-axes force ``f`` at body point ``p`` gives the body-axes torque ``(p - c) x f`` about
the centre of mass ``c``, so every held wrench folds into two (N, 6) sums (world and body
axes, force then torque) rebuilt only for the body whose holdings change; a stage then costs
one rotation per body holding a body-axes wrench, whatever the number of wrenches.
"""
import heapq
import itertools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper
from rigid_sim.core.effects.base import body_kernel_for
from rigid_sim.core.input_values import checked, NormLimit

FRAMES = ('world', 'body', 'point', 'world_point')
DEFAULT_MAX_FORCE = 1.0e4   # N; scenes with heavy bodies raise it in `limits`
DEFAULT_MAX_TORQUE = 1.0e4  # N m
# Simulated time is a running sum of float steps (ten steps of 0.01 s end 1e-17 s short of
# 0.1), so a hold ends at the step that reaches its end to within this: a ROS stamp's
# resolution. Without it a hold whose end falls on a step would act one step too long.
EXPIRY_SLACK = 1e-9   # s


@dataclass(frozen=True)
class HeldWrench:
    """One wrench as held (a ``point`` force already folded into body force and torque)."""

    body: int
    frame: str
    force: np.ndarray    # (3,) N
    torque: np.ndarray   # (3,) N m, about the centre of mass
    lever: np.ndarray    # (3,) m, body axes, from the centre of mass to a world_point force
    expires: float       # simulated time at which it stops acting (inf: held until replaced)


class WrenchInputs(NamedTuple):
    """The held wrenches as arrays, what the compiled kernel reads."""

    world_sum: np.ndarray    # (N, 6) world-axes force (N) and torque (N m) per body
    body_sum: np.ndarray     # (N, 6) body-axes force and torque per body
    body_held: np.ndarray    # (N,) bool: the body holds a body-axes wrench
    # The K world_point forces in order of body: body i's are rows
    # point_start[i]:point_start[i + 1] of point_lever and point_force.
    point_start: np.ndarray  # (N + 1,) int
    point_lever: np.ndarray  # (K, 3) m, body axes, from its centre of mass to the point
    point_force: np.ndarray  # (K, 3) N, world axes


class AppliedWrenches:
    """The wrenches currently held on the bodies of a scene.

    Holding, replacing or dropping a wrench re-sums only its body, so holding one on each of
    N bodies costs O(N); the derived arrays are refreshed once, at the next evaluation.
    """

    def __init__(self, bodies, max_force=DEFAULT_MAX_FORCE, max_torque=DEFAULT_MAX_TORQUE,
                 accepts=None):
        self._bodies = bodies
        self.max_force = float(max_force)
        self.max_torque = float(max_torque)
        count = bodies.count
        # {body: {key: HeldWrench}}, and the world_point ones again under (body, key).
        self._by_body = {}
        self._at_points = {}
        self._sums = {'world': np.zeros((count, 6)), 'body': np.zeros((count, 6))}
        self._body_held = np.zeros(count, dtype=bool)
        # (N,) bool: the bodies holding a wrench now (the step guard reads it every step).
        self.held_mask = np.zeros(count, dtype=bool)
        # (N,) bool: the bodies that held a wrench since the world last took stock of its
        # conserved quantities (World.invariant_drift reports the others).
        self.touched = np.zeros(count, dtype=bool)
        # Bodies that take wrench input: (N,) bool, all by default.
        self.accepts_wrench = (np.ones(count, dtype=bool) if accepts is None
                               else np.array(accepts, bool))
        # A heap of (expires, order, body, key, wrench): a hold that changes or ends costs
        # O(log n), not a walk over all n held wrenches.
        self._expiries = []
        self._order = itertools.count()
        # The earliest end in that heap (inf: none; an entry of a hold replaced or released
        # since counts until expire pops it): expire(t) drops nothing while
        # t + EXPIRY_SLACK < next_expiry, so a step need not call it.
        self.next_expiry = np.inf
        self._points_stale = True
        self._refresh()
        # Counts every change of the holdings: the step guard's cached spin is of one version.
        self.version = 0

    def check(self, force, torque):
        """Return (3,) force and torque if they pass the input checks, else ValueError.

        The checks are every input's (:func:`rigid_sim.core.input_values.checked`: finite,
        not subnormal, within the number bound) and the scene's ``max_force`` and
        ``max_torque`` on the magnitudes.
        """
        return (checked('force', force, limit=NormLimit(self.max_force, 'max_force', 'N')),
                checked('torque', torque, limit=NormLimit(self.max_torque, 'max_torque', 'N m')))

    def hold(self, body, key, frame, force, torque=(0.0, 0.0, 0.0), point=None,
             expires=np.inf):
        """Hold a wrench on ``body`` until ``expires``, replacing the one under ``key``.

        Raises ValueError, and changes nothing, for a non-finite or above-limit wrench or
        an unknown frame.
        """
        if frame not in FRAMES:
            raise ValueError(f'unknown wrench frame {frame!r}; valid: {FRAMES}')
        if not self.accepts_wrench[body]:
            raise ValueError(f'body {self._bodies.names[body]!r} takes no wrench input')
        force, torque = self.check(force, torque)
        lever = np.zeros(3)
        if frame in ('point', 'world_point'):
            lever = checked('point', point) - self._bodies.com_in_body[body]
        if frame == 'point':
            torque = torque + np.cross(lever, force)
            frame = 'body'
        held = HeldWrench(body, frame, force, torque, lever, float(expires))
        self.touched[body] = True
        if key in self._by_body.get(body, {}):
            self._take(body, key)
        self._by_body.setdefault(body, {})[key] = held
        if frame == 'world_point':
            self._at_points[(body, key)] = held
            self._points_stale = True
        if held.expires < np.inf:
            heapq.heappush(self._expiries, (held.expires, next(self._order), body, key, held))
            self.next_expiry = self._expiries[0][0]
        self._resum(body)

    def release(self, body=None, key=None):
        """Drop the wrench under (body, key), or all of them when called with no arguments."""
        if body is None:
            dropped = list(self._by_body)
            self._by_body.clear()
            self._at_points.clear()
            self._expiries.clear()
            self.next_expiry = np.inf
            self._points_stale = True
        else:
            dropped = [body]
            if key in self._by_body.get(body, {}):
                self._take(body, key)
        for index in dropped:
            self._resum(index)

    def expire(self, time):
        """Drop wrenches whose hold has run out by simulated ``time``."""
        time += EXPIRY_SLACK
        ended = set()
        while self._expiries and self._expiries[0][0] <= time:
            _, _, body, key, held = heapq.heappop(self._expiries)
            # Entries of wrenches replaced or released since are skipped as they come up.
            if self._by_body.get(body, {}).get(key) is held:
                self._take(body, key)
                ended.add(body)
        self.next_expiry = self._expiries[0][0] if self._expiries else np.inf
        for body in ended:
            self._resum(body)

    def _take(self, body, key):
        """Remove the wrench held on ``body`` under ``key`` (the sums are left to _resum)."""
        held = self._by_body[body].pop(key)
        if held.frame == 'world_point':
            del self._at_points[(body, key)]
            self._points_stale = True

    def _resum(self, body):
        """Re-add the wrenches held on ``body`` into the sums, in the order they came."""
        wrenches = self._by_body.get(body)
        for sums in self._sums.values():
            sums[body] = 0.0
        for held in (wrenches or {}).values():
            sums = self._sums['body' if held.frame == 'body' else 'world']
            sums[body, :3] += held.force
            sums[body, 3:] += held.torque
        if not wrenches:
            self._by_body.pop(body, None)
        self.held_mask[body] = bool(wrenches)
        self.version += 1
        self._body_held[body] = any(held.frame == 'body' for held in (wrenches or {}).values())

    def _refresh(self):
        """Rebuild the kernel's arrays after the world_point holdings changed (the sums stay)."""
        # A stable sort: each body's forces keep the order they came in.
        at_points = sorted(self._at_points.values(), key=lambda held: held.body)
        counts = np.bincount(np.array([w.body for w in at_points], dtype=np.int64),
                             minlength=self._bodies.count)
        self._parameters = WrenchInputs(
            self._sums['world'], self._sums['body'], self._body_held,
            np.concatenate(([0], np.cumsum(counts))).astype(np.int64),
            np.array([w.lever for w in at_points], dtype=float).reshape(-1, 3),
            np.array([w.force for w in at_points], dtype=float).reshape(-1, 3))
        self._points_stale = False

    @property
    def parameters(self):
        """Return the :class:`WrenchInputs` the compiled kernel reads."""
        if self._points_stale:
            self._refresh()
        return self._parameters

    @property
    def held(self):
        """Held wrenches, keyed by (body, key)."""
        return {(body, key): w for body, wrenches in self._by_body.items()
                for key, w in wrenches.items()}


@body_kernel_for(WrenchInputs)
@helper
def wrench_input(p, i, x, q, momentum, big_l, time, model):
    """Body ``i``'s held wrenches, world axes, about its centre of mass, at quaternion ``q``."""
    force = kin.vector(p.world_sum, i, 0)
    torque = kin.vector(p.world_sum, i, 3)
    if p.body_held[i] or p.point_start[i] < p.point_start[i + 1]:
        r = kin.matrix(q)
        if p.body_held[i]:
            force = kin.add(force, kin.rotate(r, kin.vector(p.body_sum, i, 0)))
            torque = kin.add(torque, kin.rotate(r, kin.vector(p.body_sum, i, 3)))
        for j in range(p.point_start[i], p.point_start[i + 1]):
            arm = kin.rotate(r, kin.vector(p.point_lever, j, 0))
            torque = kin.add(torque, kin.cross(arm, kin.vector(p.point_force, j, 0)))
    return force, torque
