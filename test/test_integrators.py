# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Integrators: the registry, convergence orders, and the contract every method keeps."""
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import physics_cases as cases
from physics_cases import TILT
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import SpringSpec, Springs
from rigid_sim.core.integrators import REGISTRY, make_integrator
from rigid_sim.core.state import ORIENTATION, POSITION

# A body on a spring from an off-centre point, under gravity: translation and rotation coupled.
SPRUNG = cases.SingleBody(
    mass=1.2, inertia=TILT.as_matrix() @ np.diag([0.3, 0.5, 0.7]) @ TILT.as_matrix().T,
    lever=np.array([0.15, -0.1, 0.2]), anchor=np.array([0.0, 0.0, 1.0]),
    stiffness=30.0, damping=0.4, gravity=np.array([0.4, -0.3, -9.81]))
START = dict(x0=np.array([0.3, -0.2, 0.8]), v0=np.array([0.2, 0.5, -0.1]),
             q0=TILT.inv().as_quat(), omega_body0=np.array([1.0, -2.0, 3.0]))
DURATION = 0.5  # s
OBSERVED_ORDER_SLACK = 0.3
# Coarsest of three step sizes per order, chosen in the asymptotic range (error well above
# rounding, leading error term dominant).
COARSEST_STEP = {1: 4e-3, 2: 2e-2}
HIGH_ORDER_COARSEST_STEP = 2.5e-2


def sprung_world(name, tolerance=1e-6, case=SPRUNG):
    """``case`` as a core World: its frame origin at the centre of mass, at START."""
    bodies = cases.make_bodies(SPRUNG.mass, SPRUNG.inertia)
    spring = SpringSpec(body=0, point=case.lever, stiffness=case.stiffness,
                        damping=case.damping, anchor=case.anchor)
    effects = [Springs(bodies, [spring]), Gravity(bodies, case.gravity)]
    q0 = START['q0']
    omega = Rotation.from_quat(q0).apply(START['omega_body0'])
    return cases.make_world(bodies, START['x0'], q0, START['v0'], omega, effects, name, tolerance)


def sprung_reference(case=SPRUNG):
    """Position (3,) and orientation (4,) of ``case`` at DURATION, by DOP853."""
    x, _, q, _ = case.reference(START['x0'], START['v0'], START['q0'],
                                START['omega_body0'], np.array([DURATION]))
    return x[0], q[0]


def sprung_error(world, reference):
    """|x - x_ref| in m plus the orientation error in rad (body size ~1 m)."""
    x_reference, q_reference = reference
    return (np.linalg.norm(world.y[0, POSITION] - x_reference)
            + cases.rotation_error(world.y[0, ORIENTATION], q_reference))


@pytest.fixture(scope='module')
def reference():
    return sprung_reference()


@pytest.mark.parametrize('damping', [0.0, SPRUNG.damping], ids=['undamped', 'damped'])
@pytest.mark.parametrize('name', cases.FIXED_STEP)
def test_convergence_order(name, damping):
    """A method of order p has global error C dt^p: halving dt divides it by 2^p.

    The observed slope of log(error) against log(dt) over three step sizes is within 0.3 of
    cls.order, with forces of position only (undamped) and of velocity too (damped).
    """
    case = replace(SPRUNG, damping=damping)
    reference = sprung_reference(case)
    order = REGISTRY[name].order
    coarsest = COARSEST_STEP.get(order, HIGH_ORDER_COARSEST_STEP)
    steps = coarsest / np.array([1.0, 2.0, 4.0])
    errors = [sprung_error(cases.advance(sprung_world(name, case=case), dt, DURATION), reference)
              for dt in steps]
    observed = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert abs(observed - order) < OBSERVED_ORDER_SLACK, (errors, observed)


def test_dopri5_error_falls_with_tolerance(reference):
    """An error-controlled method meets a tighter tolerance with a smaller error.

    A hundredfold tighter tolerance gives at least a tenfold smaller error, and the error stays
    near it.
    """
    tolerances = [1e-5, 1e-7, 1e-9]
    errors = [sprung_error(cases.advance(sprung_world('dopri5', tolerance), 0.1, DURATION),
                           reference) for tolerance in tolerances]
    assert all(tighter < looser / 10 for looser, tighter in zip(errors, errors[1:])), errors
    assert all(error < 20 * tolerance for error, tolerance in zip(errors, tolerances)), errors


def test_unknown_integrator_is_refused_with_the_valid_names():
    """A misspelt integrator name is a ValueError that lists every registered name."""
    world = sprung_world('rk4')
    for build in (lambda: make_integrator('rk5', world),
                  lambda: type(world)(world.bodies, world.initial, integrator='rk5')):
        with pytest.raises(ValueError) as refusal:
            build()
        assert 'rk5' in str(refusal.value)
        assert all(name in str(refusal.value) for name in REGISTRY)


@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_registry_names_and_orders(name):
    """Each registered class answers to its own name and declares a positive order."""
    cls = REGISTRY[name]
    assert cls.name == name
    assert isinstance(cls.order, int) and cls.order >= 1


@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_step_keeps_unit_quaternions_and_leaves_its_input(name):
    """Orientations stay unit quaternions and the state a World steps from is not modified.

    The integrator owns normalisation.
    """
    world = sprung_world(name)
    y = world.y.copy()
    y[:, ORIENTATION] *= 1.0 + 1e-6   # slightly off unit, as accumulated rounding leaves it
    world.y = y
    for _ in range(20):
        before = world.y
        given = before.copy()
        assert world.step(0.05)
        np.testing.assert_array_equal(before, given)
        assert np.all(np.abs(np.linalg.norm(world.y[:, ORIENTATION], axis=1) - 1.0) < 1e-15)


def test_body_momentum_rk4_beats_world_momentum_rk4_near_intermediate_axis():
    """Near the intermediate axis, RK4 on body-axes momenta beats RK4 on world momenta.

    In body axes omega_b does not depend on q; with Baraff's world L the orientation error
    feeds back into omega.
    """
    moments, omega_body0 = np.array([1.0, 2.0, 3.0]), np.array([0.1, 5.0, 0.1])
    free_body = cases.SingleBody(mass=1.0, inertia=np.diag(moments))
    duration = 4.0
    q_reference = free_body.reference(np.zeros(3), np.zeros(3), TILT.as_quat(), omega_body0,
                                      np.array([duration]))[2][0]
    errors = {}
    for name in ('rk4', 'rk4_world'):
        world = cases.make_world(cases.make_bodies(1.0, np.diag(moments)), np.zeros(3),
                                 TILT.as_quat(), np.zeros(3), TILT.apply(omega_body0),
                                 integrator=name)
        cases.advance(world, 1e-2, duration)
        errors[name] = cases.rotation_error(world.y[0, ORIENTATION], q_reference)
    assert errors['rk4'] * 100 < errors['rk4_world'], errors
