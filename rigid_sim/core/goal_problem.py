# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""One goal as equations: unknowns -> start of the flight -> residual at the goal's time.

The twist unknowns enter the packed state linearly (the pose stays):
``P = M (v + omega x R c)`` and ``L = R I R^T omega`` for the body frame origin's velocity
``v`` and the angular velocity ``omega``, so the start rows of every copy are one matrix
product. Wrench unknowns leave the start as it is and are held on the copies instead.
"""
import math

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core.rotation import angle_between
from rigid_sim.core.body_state import body_frame_state, with_twist
from rigid_sim.core.goal_flight import (PATH_POSES, Flight, GoalRefused, collides, fly_world,
                                        free_under_exact_flow, held_without_goal)

# Unknowns -> how many; which parts of the residual they aim at (position, orientation).
UNKNOWNS = {'twist': (6, (True, True)), 'linear': (3, (True, False)),
            'angular': (3, (False, True)), 'wrench': (6, (True, True))}
TOLERANCE = 1e-10      # m and rad at which the iterations stop
# Relative: solutions whose distances (:meth:`GoalProblem.distance`) differ by less are as
# near as each other; a search keeps a solution only if it is nearer by more.
SAME_DISTANCE = 1e-9
# m and rad: close enough on the coarse flight, which itself errs by more (see _coarse).
COARSE_TOLERANCE = 1e-3
FD_STEP = 1e-7         # of each unknown's displacement scale: the forward differences
# Flights cheaper than this (row-substeps of all copies) renew the Jacobian at every iterate.
FRESH_WORK = 2_500
MAX_FLIGHT_WORK = 4_000_000   # row-substeps of one flight of every copy, at most
# A coarse flight's (rate + spin) x step, and how many times fewer steps it must take
# than the fine flight to be worth solving first.
COARSE_STEP = 0.2
COARSE_GAIN = 4
# Why a goal whose flight meets contact in velocity mode is refused: its copies fly free.
VELOCITY_MODE = (
    'the flight to the goal meets contact, and goals through contact need effects: '
    'contact: {mode: exact}: velocity mode resolves an impact where a step ends, so the '
    'pose at the goal\'s time jumps as the impact moves from one step to the next')


def rotation_vector(q):
    """Rotation vectors (N, 3), angles in [0, pi], of unit quaternions (N, 4) (x, y, z, w)."""
    q = np.where(q[:, 3:] < 0.0, -q, q)
    sine = np.linalg.norm(q[:, :3], axis=1)
    angle = 2.0 * np.arctan2(sine, q[:, 3])
    # angle / sin(angle / 2) -> 2 / cos(angle / 2) as the angle vanishes.
    tiny = sine < 1e-8
    scale = np.where(tiny, 2.0 / q[:, 3], angle / np.where(tiny, 1.0, sine))
    return q[:, :3] * scale[:, None]


def left_product(p):
    """(4, 4) matrix of ``q -> p q`` for the quaternion ``p`` (x, y, z, w)."""
    x, y, z, w = p
    return np.array([[w, -z, y, x], [z, w, -x, y], [-y, x, w, z], [-x, -y, -z, w]])


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


class GoalProblem:
    """The equations of one goal on a solver's world, as it is now.

    Parameters
    ----------
    solver : rigid_sim.core.goals.GoalSolver
    goal : rigid_sim.core.goals.Goal
    position, orientation : (3,), (4,) float
        The goal pose, checked.
    """

    def __init__(self, solver, goal, position, orientation):
        world, index = solver.world, goal.body
        self.world, self.goal, self.index = world, goal, index
        self.aim_at(position, orientation)
        self.goal_pose = self.target
        # A copy: Rotation.apply refuses a read-only array, which a scene's may be.
        self._lever = np.array(world.bodies.com_in_body[index], dtype=float)
        self.count, self.aims = UNKNOWNS[goal.unknowns]
        self.wrench = goal.unknowns == 'wrench'
        self.y = world.y.copy()
        held = held_without_goal(world, index)
        self.collides = collides(world, index)
        self.exact = not self.wrench and free_under_exact_flow(world, index, held)
        grid = solver.time_step or goal.at - world.time
        steps = round((goal.at - world.time) / grid)
        if steps < 1:
            raise GoalRefused(f'the goal time {goal.at!r} s is less than one step of '
                              f'{grid!r} s after {world.time!r} s')
        self.grid = Flight(world, steps, grid, held)
        self.horizon = steps * grid
        self._linear_map()
        # A free flight under the exact flow is one step, exact whatever its length.
        self.fine = Flight(world, 1, self.horizon, held) if self.exact else self.grid
        if not self.exact:
            self.fine.plan_from(world, self.y)
        self.coarse = self._coarse(held)
        self.batch = solver.rollout(index, goal.unknowns, goal.axes, self.count + 1)
        self.single = solver.rollout(index, goal.unknowns, goal.axes, 1)
        self.fly_on(self.fine if self.coarse is None else self.coarse)

    def aim_at(self, position, orientation):
        """Aim the residual at ``position`` (3,) and unit ``orientation`` (4,)."""
        self.target = position, orientation
        # q -> q_goal^-1 q as one matrix, the rotation error of many rows in one product.
        self._aim = position, left_product(Rotation.from_quat(orientation).inv().as_quat()).T

    def on_the_way(self, fraction):
        """Return the pose a ``fraction`` of the way from the current motion's end to the goal.

        The position on the straight line, the orientation on the shortest turn (slerp).
        """
        position, orientation = self.goal_pose
        if fraction >= 1.0:
            return position, orientation
        end, turn = self._current_end()
        gap = rotation_vector((left_product(orientation) @ turn.inv().as_quat())[None])[0]
        return (end + fraction * (position - end),
                (Rotation.from_rotvec(fraction * gap) * turn).as_quat())

    def _current_end(self):
        """Return where the current motion ends: origin (3,) m and Rotation."""
        final, _ = self.single.fly(self.start_rows(self.current[None]),
                                   self.current[None] if self.wrench else None)
        if not np.isfinite(final).all():
            raise GoalRefused('the flight of the current motion is not finite')
        turn = Rotation.from_quat(final[0, 3:7])
        return final[0, :3] - turn.apply(self._lever), turn

    def _coarse(self, held):
        """Return a flight of far fewer steps, or None: where a long flight's solve starts.

        Its steps resolve the scene's fastest rate and the spin to COARSE_STEP; its
        solution and Jacobian start the solve on the fine flight, which then takes a few
        one-copy flights instead of many Jacobians (a coarse-to-fine solve).
        """
        rate = max([0.0] + [effect.fastest_rate() for effect in self.world.effects])
        spin = np.linalg.norm(self._twist[1])
        steps = math.ceil(self.horizon * (rate + spin + np.pi / self.horizon) / COARSE_STEP)
        fine = sum(n * s for n, s in self.fine.plan)
        if COARSE_GAIN * steps > fine:
            return None
        return Flight(self.world, steps, self.horizon / steps, held)

    def fly_on(self, flight):
        """Fly the rollouts over ``flight`` from now on."""
        work = sum(s * n for n, s in flight.plan) * (self.count + 1) * self.batch.copies.width
        if work > MAX_FLIGHT_WORK:
            raise GoalRefused(f'the goal needs {work} body-substeps per flight of its '
                              f'{self.count + 1} copies, above {MAX_FLIGHT_WORK}')
        self.flight, self.fresh = flight, work <= FRESH_WORK
        self.batch.prepare(flight, self.y)
        self.single.prepare(flight, self.y)

    def _linear_map(self):
        """Start momenta = A u + b; the scale and difference steps of the unknowns."""
        bodies, index = self.world.bodies, self.index
        _, q, velocity, spin = body_frame_state(bodies, self.y, index)
        self._twist = velocity, spin
        turn = Rotation.from_quat(q).as_matrix()
        mass = bodies.mass[index]
        lever = _skew(turn @ bodies.com_in_body[index])
        inertia = turn @ bodies.inertia_body[index] @ turn.T
        columns = {'linear': np.vstack((mass * np.eye(3), np.zeros((3, 3)))),
                   'angular': np.vstack((-mass * lever, inertia))}
        current = {'linear': velocity, 'angular': spin}
        unknowns = self.goal.unknowns
        parts = ('linear', 'angular') if unknowns in ('twist', 'wrench') else (unknowns,)
        self.a = np.hstack([columns[p] for p in parts])
        fixed = [p for p in ('linear', 'angular') if p not in parts]
        self.b = sum((columns[p] @ current[p] for p in fixed), np.zeros(6))
        self.current = (np.zeros(6) if self.wrench
                        else np.concatenate([current[p] for p in parts]))
        self.turn, self.inertia, self.mass, self._lever_matrix = turn, inertia, mass, lever
        horizon = self.horizon
        if self.wrench:   # the displacement of a force or torque held for the horizon
            moment = np.trace(bodies.inertia_body[index]) / 3.0
            self.scale = 0.5 * horizon ** 2 / np.repeat([mass, moment], 3)
            # The impulse of the wrench held for the horizon, world axes.
            impulse = horizon * np.eye(6)
            if self.goal.axes == 'body':
                impulse[:3, :3], impulse[3:, 3:] = horizon * turn, horizon * turn
        else:
            self.scale = np.full(self.count, horizon)
            impulse = self.a   # a change of twist is the impulse a @ change
        # The metric of "nearest": |change|^2 = |dP|^2 / m + dL . I^-1 dL, twice the kinetic
        # energy the change's impulse (dP, dL about the centre of mass) gives a body at rest.
        energy = np.zeros((6, 6))
        energy[:3, :3], energy[3:, 3:] = np.eye(3) / mass, np.linalg.inv(inertia)
        self.metric = impulse.T @ energy @ impulse

    def distance(self, values):
        """Return how far the unknowns (n,) are from the current motion, sqrt(kg) m/s.

        The square root of twice the kinetic energy the impulse of the change would give
        the body at rest: the metric by which the solver takes the nearest solution.
        """
        change = values - self.current
        return float(np.sqrt(max(change @ self.metric @ change, 0.0)))

    def whole_turns(self, values, first):
        """Return changes (K, n) of the unknowns that add a whole turn at the goal's time.

        The orientation at the goal's time is periodic in the spin: a free body spinning
        ``omega`` reaches the same orientation spinning ``omega + 2 pi k a / T`` about its
        own axis ``a``, so the solutions lie on branches 2 pi / T apart. Other bodies' axes
        drift from that, so both the solution's spin axis and its angular momentum's are
        shifted along (and, for the first iterate, the axis of the turn it corrects).
        Linear unknowns reach a position, which has no such branches: none.
        """
        if self.goal.unknowns == 'linear':
            return np.zeros((0, self.count))
        spin = values[-3:]
        axes = [spin, self.inertia @ spin, first[-3:] - self.current[-3:]]
        if self.wrench:   # the torque's axis, world axes, and the current spin's
            axes = [self.turn @ spin if self.goal.axes == 'body' else spin, self._twist[1]]
        shifts = []
        for axis in axes:
            size = np.linalg.norm(axis)
            if not size > 0.0:
                continue
            turn = 2.0 * np.pi * axis / size
            for k in (-1.0, 1.0):
                shifts.append(self._turn_change(k * turn))
        return np.array(shifts).reshape(-1, self.count)

    def _turn_change(self, turn):
        """Change (n,) of the unknowns that adds the rotation vector ``turn`` at arrival."""
        if self.wrench:   # a torque held from rest turns by tau T^2 / (2 I)
            torque = 2.0 * self.inertia @ turn / self.horizon ** 2
            if self.goal.axes == 'body':
                torque = self.turn.T @ torque
            return np.concatenate((np.zeros(3), torque))
        return self.spin_shift() @ (turn / self.horizon)

    def spin_shift(self):
        """Return (n, 3): the change of twist or angular unknowns a change of spin makes.

        The centre of mass keeps its velocity: the origin's changes by -spin x (R c).
        """
        if self.goal.unknowns == 'angular':
            return np.eye(3)
        return np.vstack((self._lever_matrix, np.eye(3)))

    def start_rows(self, values):
        """Start rows (K, 13) of the body from unknowns (K, n)."""
        rows = np.repeat(self.y[self.index][None], len(values), axis=0)
        if not self.wrench:
            rows[:, 7:13] = values @ self.a.T + self.b
        return rows

    def residuals(self, values):
        """Residuals (K, m) at unknowns (K, n): the aimed parts; NaN for failed flights."""
        rollout = self.batch if len(values) > 1 else self.single
        final, _ = rollout.fly(self.start_rows(values), values if self.wrench else None)
        return self.residual_of(final)

    def residual_of(self, final):
        """Residuals (K, m) of final states (K, 13) of the body."""
        position, inverse = self._aim
        parts = []
        if self.aims[0]:
            origin = final[:, :3]
            if self._lever.any():
                # A failed flight's row is all NaN, which Rotation refuses: its origin stays
                # NaN whatever turns its lever.
                q = np.where(np.isnan(final[:, 3:7]), 1.0, final[:, 3:7])
                origin = origin - Rotation.from_quat(q).apply(self._lever)
            parts.append(origin - position)
        if self.aims[1]:
            parts.append(rotation_vector(final[:, 3:7] @ inverse))
        return np.hstack(parts)

    def errors(self, final):
        """Position error (m) and orientation error (rad) of the final state (13,)."""
        if not np.isfinite(final).all():
            raise GoalRefused('the flight at the solution is not finite')
        turn = Rotation.from_quat(final[3:7])
        position, orientation = self.target
        offset = final[:3] - turn.apply(self._lever) - position
        angle = angle_between(orientation[None], final[None, 3:7])[0]
        return float(np.linalg.norm(offset)), float(angle)

    def poses(self, trace):
        """Return times (M,), origins (M, 3), orientations (M, 4) of a trace, or None.

        ``trace``: [(time, state (13,))] of the body.
        """
        if not trace:
            return None
        times = np.array([time for time, _ in trace])
        states = np.array([state for _, state in trace])
        levers = Rotation.from_quat(states[:, 3:7]).apply(self._lever)
        return times, states[:, :3] - levers, states[:, 3:7].copy()

    @staticmethod
    def close_enough(residual, tolerance=TOLERANCE):
        """Whether each aimed part of ``residual`` is within ``tolerance`` (m, rad)."""
        squares = residual * residual
        return bool(np.all(squares.reshape(-1, 3).sum(axis=1) <= tolerance ** 2))

    @property
    def steps(self):
        """(n,) steps of the forward differences, in the unknowns' units."""
        return FD_STEP * np.maximum(1.0, np.abs(self.current) * self.scale) / self.scale

    def first_iterate(self):
        """Return the current motion corrected by the least move that closes its gap."""
        end, turn = self._current_end()
        position, orientation = self.target
        gap = position - end
        turn_gap = rotation_vector((left_product(orientation)
                                    @ turn.inv().as_quat())[None])[0]
        if self.wrench:
            force = 2.0 * self.mass * gap / self.horizon ** 2
            torque = 2.0 * self.inertia @ turn_gap / self.horizon ** 2
            if self.goal.axes == 'body':
                force, torque = self.turn.T @ force, self.turn.T @ torque
            return np.concatenate((force, torque))
        moves = {'linear': gap, 'angular': turn_gap, 'twist': np.concatenate((gap, turn_gap))}
        return self.current + moves[self.goal.unknowns] / self.horizon

    def world_start(self, values):
        """Return the world's state with the unknowns applied, as ``GoalSolver.apply`` does."""
        if self.wrench:
            return self.y
        linear, angular = self.twist(values)
        return with_twist(self.world.bodies, self.y, self.index, linear, angular)

    def twist(self, values):
        """Return the body frame's (linear, angular) velocity the twist ``values`` set."""
        velocity, spin = self._twist
        if self.goal.unknowns == 'linear':
            return values, spin
        if self.goal.unknowns == 'angular':
            return velocity, values
        return values[:3], values[3:]

    def verified(self, newton, want_path, attempts=3):
        """Return the final state (13,) and path of the world's own flight at the solution.

        The world's guard may take other substeps than planned: the solve then goes on
        with the plan it took (or, on the same plan, with a chord step) and flies again.
        """
        if self.exact:
            return self._free_flight(newton.values, want_path)
        every = max(1, self.grid.steps // PATH_POSES) if want_path else 0
        for attempt in range(attempts):
            self._check_limits(newton.values)
            final, plan, path, capped, touched = fly_world(
                self.world, self.world_start(newton.values), self.grid,
                newton.values if self.wrench else None, self.goal.axes, self.index, every)
            if final is None or capped:
                raise GoalRefused('the motion needs more substeps than the step guard '
                                  'allows' if capped else 'the world gave a step up')
            if touched and self.world.contact.exact is None:
                raise GoalRefused(VELOCITY_MODE)
            residual = self.residual_of(final[self.index][None])[0]
            if self.close_enough(residual) or attempt + 1 == attempts:
                break
            if plan != self.fine.plan:
                self.fine.plan = plan
                self.fly_on(self.fine)
                newton.residual = None
                newton.converge(TOLERANCE)
            else:
                newton.chord(residual)
        return final[self.index], path

    def _free_flight(self, values, want_path):
        final, _ = self.single.fly(self.start_rows(values[None]))
        path = []
        if want_path:
            poses = min(PATH_POSES, self.grid.steps)
            self.single.prepare(Flight(self.world, poses, self.horizon / poses,
                                       self.fine.held), self.y)
            _, path = self.single.fly(self.start_rows(values[None]), every=1)
            path = [(t, rows[0]) for t, rows in path]
        return final[0], path

    def _check_limits(self, values):
        """Refuse a wrench the scene's limits refuse (as a held wrench would be)."""
        if self.wrench:
            try:
                self.world.inputs.check(values[:3], values[3:])
            except ValueError as error:
                raise GoalRefused(f'the goal needs {error}') from None
