# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Two-sided shooting: the time-reversed copies, and what the meetings are for.

The reversed copies are checked without an oracle, by the physics of time reversal: flown
forward and then reversed for as long, a body returns to where it started, to within the
flight's own step error. The meetings are checked by the goal they exist for: a 10 s
target on the damped spring that the oracle flew to, which the solver refused without them.
"""
import numpy as np
import pytest

from test_goals import BOX, SPRING, distance, flown, oracle_pose, scene_world
from rigid_sim.core.body_state import with_twist
from rigid_sim.core.goal_copies import Copies
from rigid_sim.core.goal_problem import GoalProblem
from rigid_sim.core.goal_twosided import (ReversedCopies, TwoSided, applies, reverse)
from rigid_sim.core.goals import ACCEPTED, Goal, GoalSolver

SECONDS, DT, SUBSTEPS = 5.0, 1e-2, 2
OTHER = dict(BOX, name='other', pose={'position': [1.0, 0.0, 0.5]}, twist={})
SCENES = {
    'an anchored damped spring and momentum damping': (
        {'springs': [SPRING], 'damping': {'linear': 0.5, 'angular': 0.3}}, (BOX,)),
    'a damped spring between two bodies': (
        {'springs': [{'body': 'box', 'other': 'other', 'stiffness': 5.0, 'damping': 0.4,
                      'point': [0.05, 0.0, 0.0], 'rest_length': 0.5}]}, (BOX, OTHER)),
}


def forward(world, y, dt):
    """Return the group's rows ``y`` flown SECONDS by copies of the world's, steps of ``dt``."""
    y = y.copy()
    Copies(world, 0, 1).advance(y, 0.0, round(SECONDS / dt), dt, SUBSTEPS)
    return y


@pytest.mark.parametrize('scene', sorted(SCENES))
def test_the_reversed_copies_fly_the_world_back_to_where_it_started(scene):
    """Forward, then reversed (momenta and dampers negated): back within the step error.

    The step error is the difference between the flight at DT and at DT / 2. Flown back with
    the momenta negated but the dampers as they are, the body misses by far more: the
    dampers have taken energy the reversed flight must give back.
    """
    world = scene_world(*SCENES[scene])
    start = world.y.copy()
    there = forward(world, start, DT)
    step_error = np.abs(there - forward(world, start, DT / 2)).max()
    back = reverse(there)
    ReversedCopies(world, 0, 1).advance(back, 0.0, round(SECONDS / DT), DT, SUBSTEPS)
    assert np.abs(reverse(back) - start).max() <= step_error
    undamped = forward(world, reverse(there), DT)
    assert np.abs(reverse(undamped) - start).max() >= 100.0 * step_error


def test_the_halves_of_a_flight_meet_at_its_twist_at_the_goal_time_and_only_there():
    """The goal is where a twist's flight ends: that twist and its end twist meet."""
    world = scene_world({'springs': [SPRING]})
    twist = np.array([-0.16, -0.23, 0.25, 1.44, 2.1, 2.69])
    end = with_twist(world.bodies, world.y, 0, twist[:3], twist[3:])
    Copies(world, 0, 1).advance(end, 0.0, round(10.0 / DT), DT, SUBSTEPS)
    goal = Goal(0, end[0, :3], end[0, 3:7], 10.0)   # the box's centre is its origin
    problem = GoalProblem(GoalSolver(world, DT), goal, goal.position, goal.orientation)
    assert applies(problem)
    sides = TwoSided(problem)
    assert sides.substeps == SUBSTEPS
    arrival = sides.end_twist(twist)
    met = sides.residuals(np.array([np.concatenate((twist, arrival)),
                                    np.concatenate((twist, arrival + 0.01))]))
    assert np.abs(met[0]).max() <= 1e-8
    assert np.abs(met[1]).max() >= 1e-3


def test_a_ten_second_spring_goal_refused_without_the_meetings_is_reached():
    """T = 10 s on the damped spring: a target the oracle flew to, reached by the World.

    Made by the oracle's flight of a change of (-0.26, -0.23, 0.25) m/s and
    (0.44, 0.1, -0.31) rad/s; none of the other starts converge (main refused it: 17
    starts, 1915 flights), a meeting's does.
    """
    effects, until = {'springs': [SPRING]}, 10.0
    twist = np.array([-0.16, -0.23, 0.25, 1.44, 2.1, 2.69])
    goal = Goal(0, *oracle_pose(effects, twist[:3], twist[3:], until), until)
    world = scene_world(effects)
    solver = GoalSolver(world, DT)
    solver.apply(solver.solve(goal))
    assert max(distance(flown(world, DT, until), goal)) <= ACCEPTED
