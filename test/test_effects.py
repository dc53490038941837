# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Effects add the wrenches physics says they do, and effects a world does not list never run."""
import importlib
import inspect
import pkgutil
from typing import NamedTuple

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import physics_cases as cases
from physics_cases import TILT
import rigid_sim.core.effects
from rigid_sim.core.effects import REGISTRY as EFFECTS, registry
from rigid_sim.core.inputs import AppliedWrenches, WrenchInputs
from rigid_sim.core.effects.base import Effect, acts_per_body
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity, GravityParameters
from rigid_sim.core.effects.springs import SpringSpec, Springs
from rigid_sim.core.integrators import REGISTRY
from rigid_sim.core.scene_fields import raw
from rigid_sim.core.state import ANGULAR_MOMENTUM, LINEAR_MOMENTUM, POSITION

INERTIA = TILT.as_matrix() @ np.diag([0.03, 0.05, 0.07]) @ TILT.as_matrix().T
COM = np.array([0.1, -0.05, 0.02])   # m, centre of mass in the body frame
OMEGA = np.array([3.0, -2.0, 4.0])    # rad/s, world
GRAVITY = np.array([0.4, -0.3, -9.81])


def tumbling(make_effects=lambda bodies: [], integrator='rk4', tolerance=1e-6):
    """One 1.5 kg asymmetric body, centre of mass off its frame, tumbling and moving."""
    bodies = cases.make_bodies(1.5, INERTIA, COM)
    return cases.make_world(bodies, (0.2, -0.1, 1.0), TILT.as_quat(), (0.5, 0.0, 1.0), OMEGA,
                            make_effects(bodies), integrator, tolerance)


def net_wrench(world):
    """Net world force and torque about the centre of mass on body 0, (3,) each."""
    force, torque = world.wrench(world.snapshot())
    return force[0], torque[0]


@pytest.mark.parametrize('name', cases.ACCURATE)
def test_damping_decays_momenta_exponentially(name):
    """Damping makes the momenta decay exponentially and the kinetic energy fall.

    F = -c P and tau = -c' L give P = P0 exp(-c t) and L = L0 exp(-c' t) (L keeps its world
    direction while the body tumbles), x = x0 + v0 (1 - exp(-c t)) / c, and a kinetic energy
    that falls at every step: dE/dt = -c P^2 / M - c' omega.L < 0.
    """
    linear, angular, dt = 0.8, 0.5, 5e-3
    world = tumbling(lambda bodies: [Damping(bodies, linear, angular)], name,
                     cases.ADAPTIVE_TOLERANCE)
    x0, p0, l0 = (world.y[0, part].copy() for part in (POSITION, LINEAR_MOMENTUM,
                                                       ANGULAR_MOMENTUM))
    energies = [world.energy()]
    for _ in range(200):
        world.step(dt)
        energies.append(world.energy())
    t = world.time
    allowed = cases.allowed_error(name, np.linalg.norm(OMEGA), dt)
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM], p0 * np.exp(-linear * t),
                               rtol=0, atol=allowed * np.linalg.norm(p0))
    np.testing.assert_allclose(world.y[0, ANGULAR_MOMENTUM], l0 * np.exp(-angular * t),
                               rtol=0, atol=allowed * np.linalg.norm(l0))
    np.testing.assert_allclose(world.y[0, POSITION],
                               x0 + p0 / 1.5 * (1.0 - np.exp(-linear * t)) / linear,
                               rtol=0, atol=allowed * np.linalg.norm(p0))
    assert np.all(np.diff(energies) < 0.0)


def test_gravity_never_torques():
    """Uniform gravity acts at the centre of mass.

    Exactly M g on each body and no torque whatever the pose, and it is declared torque-free so
    integrators may rely on it.
    """
    bodies = cases.make_bodies([1.5, 0.3], [INERTIA, 2 * INERTIA], [COM, -3 * COM])
    gravity = Gravity(bodies, GRAVITY)
    generator = np.random.default_rng(7)
    world = cases.make_world(bodies, generator.normal(size=(2, 3)),
                             Rotation.random(2, random_state=7).as_quat(),
                             generator.normal(size=(2, 3)), generator.normal(size=(2, 3)),
                             [gravity])
    force, torque = world.wrench(world.snapshot())
    np.testing.assert_array_equal(force, bodies.mass[:, None] * GRAVITY)
    np.testing.assert_array_equal(torque, np.zeros((2, 3)))
    assert not gravity.torqued.any() and not world.torqued.any()


def test_gravity_potential_makes_energy_conserved():
    """Kinetic energy plus -M g.x is conserved in free fall.

    rk4 integrates the parabola exactly, and the rotation is torque-free.
    """
    world = tumbling(lambda bodies: [Gravity(bodies, GRAVITY)])
    start = world.energy()
    cases.advance(world, 5e-3, 1.0)
    assert abs(world.energy() - start) < 1e-9 * abs(start)


def two_bodies_on_a_spring(damping, rest_length):
    """Two tumbling bodies joined by a spring between off-centre points (rk4)."""
    bodies = cases.make_bodies([1.5, 0.8], [INERTIA, np.diag([0.03, 0.02, 0.04])],
                               [COM, [0.0, 0.05, -0.1]])
    spring = SpringSpec(body=0, point=np.array([0.2, 0.1, -0.1]), stiffness=40.0,
                        damping=damping, rest_length=rest_length, other=1,
                        other_point=np.array([-0.1, 0.0, 0.15]))
    return cases.make_world(bodies, [[0.0, 0.0, 0.0], [0.6, -0.2, 0.3]],
                            [TILT.as_quat(), TILT.inv().as_quat()],
                            [[0.3, -0.2, 0.1], [-0.4, 0.5, 0.2]], [OMEGA, [-1.0, 2.0, 0.5]],
                            [Springs(bodies, [spring])])


def total_momenta(world):
    """Total linear momentum and total angular momentum about the world origin, (3,) each."""
    y = world.y
    orbital = np.cross(y[:, POSITION], y[:, LINEAR_MOMENTUM])
    return y[:, LINEAR_MOMENTUM].sum(axis=0), (orbital + y[:, ANGULAR_MOMENTUM]).sum(axis=0)


@pytest.mark.parametrize('damping, rest_length', [(0.0, 0.0), (0.0, 0.3), (0.6, 0.3)],
                         ids=['zero-rest', 'rest-length', 'damped'])
def test_spring_between_bodies_conserves_momenta(damping, rest_length):
    """A spring pushes its two ends with equal and opposite forces along the line joining them.

    Total P and total sum(x x P + L) are conserved; energy too when undamped, and it falls when
    damped.
    """
    world = two_bodies_on_a_spring(damping, rest_length)
    momentum0, angular0 = total_momenta(world)
    energy0, first_momentum0 = world.energy(), world.y[0, LINEAR_MOMENTUM].copy()
    dt = 4e-3
    cases.advance(world, dt, 1.0)
    momentum, angular = total_momenta(world)
    np.testing.assert_allclose(momentum, momentum0, rtol=0, atol=1e-12)
    allowed = cases.allowed_error('rk4', np.linalg.norm(OMEGA), dt)
    np.testing.assert_allclose(angular, angular0, rtol=0, atol=allowed * np.linalg.norm(angular0))
    # The spring really exchanged momentum between the bodies.
    assert np.linalg.norm(world.y[0, LINEAR_MOMENTUM] - first_momentum0) > 0.1
    if damping:
        assert world.energy() < energy0 * 0.99
    else:
        assert abs(world.energy() - energy0) < allowed * energy0


def anchored_springs():
    """Three tumbling bodies: two springs to the world on the first, none on the second."""
    bodies = cases.make_bodies([1.5, 0.8, 2.0], [INERTIA, np.diag([0.03, 0.02, 0.04]), INERTIA],
                               [COM, [0.0, 0.05, -0.1], -COM])
    specs = [SpringSpec(body=2, point=np.array([0.1, 0.0, 0.3]), stiffness=25.0,
                        anchor=np.array([0.5, 0.5, 2.0])),
             SpringSpec(body=0, point=np.array([0.2, 0.1, -0.1]), stiffness=40.0, damping=0.6,
                        rest_length=0.3, anchor=np.array([0.0, 0.0, 2.0])),
             SpringSpec(body=0, point=np.array([-0.1, 0.0, 0.15]), stiffness=15.0,
                        damping=0.2, anchor=np.array([1.0, -1.0, 0.5]))]
    world = cases.make_world(bodies, [[0.0, 0.0, 0.0], [0.6, -0.2, 0.3], [-0.5, 0.4, 0.1]],
                             [TILT.as_quat(), TILT.inv().as_quat(), [0.0, 0.0, 0.0, 1.0]],
                             [[0.3, -0.2, 0.1], [-0.4, 0.5, 0.2], [0.1, 0.1, -0.3]],
                             [OMEGA, [-1.0, 2.0, 0.5], [0.5, -0.5, 2.0]],
                             [Springs(bodies, specs)])
    return world, specs


def test_springs_to_the_world_pull_by_hookes_law_one_body_at_a_time():
    """Springs that all end in the world act on one body each, so they run a body at a time.

    Each pulls its point ``p`` towards its anchor ``a`` with ``-(k (l - l0) + c dl/dt) u``,
    ``u = (p - a) / l``, at the point's velocity ``v + omega x (p - x)``, and turns its body by
    ``(p - x) x f``; two springs on one body add, and a body without one feels nothing.
    """
    world, specs = anchored_springs()
    assert acts_per_body(world.effect_parameters())
    snapshot = world.snapshot()
    force, torque = np.zeros((3, 3)), np.zeros((3, 3))
    for spec in specs:
        point = snapshot.point_world(np.array([spec.body]), spec.point[None])
        velocity = snapshot.point_velocity(np.array([spec.body]), point)[0]
        point = point[0]
        length = np.linalg.norm(point - spec.anchor)
        unit = (point - spec.anchor) / length
        if spec.rest_length:
            pull = -(spec.stiffness * (length - spec.rest_length)
                     + spec.damping * velocity @ unit) * unit
        else:
            pull = -spec.stiffness * (point - spec.anchor) - spec.damping * velocity
        force[spec.body] += pull
        torque[spec.body] += np.cross(point - world.y[spec.body, POSITION], pull)
    got_force, got_torque = world.wrench(snapshot)
    np.testing.assert_allclose(got_force, force, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(got_torque, torque, rtol=1e-13, atol=1e-13)
    assert not got_force[1].any() and not got_torque[1].any()
    assert not acts_per_body(two_bodies_on_a_spring(0.0, 0.0).effect_parameters())


def pushed(max_force=10.0, max_torque=5.0, accepts=None, integrator='rk4'):
    """Two bodies at rest at TILT, centre of mass off the frame, and their applied wrenches."""
    bodies = cases.make_bodies([1.5, 0.5], [INERTIA, INERTIA], [COM, COM])
    wrenches = AppliedWrenches(bodies, max_force, max_torque, accepts)
    world = cases.make_world(bodies, np.zeros((2, 3)), [TILT.as_quat()] * 2, np.zeros((2, 3)),
                             np.zeros((2, 3)), [], integrator, inputs=wrenches)
    return world, wrenches


@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_held_wrench_stops_acting_when_it_expires(name):
    """A force held until t1 gives the impulse F t1 and nothing after: P(t) = F min(t, t1)."""
    world, wrenches = pushed(integrator=name)
    force = np.array([2.0, -1.0, 0.5])
    wrenches.hold(0, 'world', 'world', force, expires=0.5)
    cases.advance(world, 0.125, 0.5)   # binary fractions: t1 falls exactly on a step
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM], force * 0.5, rtol=1e-12)
    cases.advance(world, 0.125, 0.5)
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM], force * 0.5, rtol=1e-12)
    assert wrenches.held == {}


def test_hold_ends_on_the_step_that_reaches_it_with_decimal_steps():
    """Ten steps of 0.01 s sum to 1e-17 s short of 0.1 s.

    A 0.1 s hold still ends there and delivers the impulse F x 0.1 s, not one step more.
    """
    world, wrenches = pushed()
    force = np.array([2.0, -1.0, 0.5])
    wrenches.hold(0, 'world', 'world', force, expires=0.1)
    for _ in range(20):
        world.step(0.01)
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM], force * 0.1, rtol=1e-12)
    assert wrenches.held == {}


def test_replacing_a_timed_hold_gives_the_new_one_its_own_end():
    """A hold replaced under its key before it ends acts until the new end, not the old one.

    0.5 s at F, then the replacement, 2 N until t = 1.5 s, so P(1 s) = F 0.25 + F2 0.75.
    """
    world, wrenches = pushed()
    force, replacement = np.array([2.0, 0.0, 0.0]), np.array([0.0, 2.0, 0.0])
    wrenches.hold(0, 'k', 'world', force, expires=0.5)
    cases.advance(world, 0.125, 0.25)
    wrenches.hold(0, 'k', 'world', replacement, expires=1.5)
    cases.advance(world, 0.125, 0.75)
    np.testing.assert_allclose(world.y[0, LINEAR_MOMENTUM], force * 0.25 + replacement * 0.75,
                               rtol=1e-12)
    assert set(wrenches.held) == {(0, 'k')}


def test_non_finite_point_of_application_is_refused():
    """A force at a NaN point would make every later step non-finite: refused, nothing held."""
    world, wrenches = pushed()
    for frame in ('point', 'world_point'):
        with pytest.raises(ValueError, match='non-finite point'):
            wrenches.hold(0, 'k', frame, [1.0, 0.0, 0.0], point=[np.nan, 0.0, 0.0])
    assert wrenches.held == {}


def test_reset_drops_held_wrenches():
    """A push held at t = 10 s until 10.1 s belongs to that run.

    After a reset to t = 0 the bodies are free again, so they stay at rest.
    """
    world, wrenches = pushed()
    cases.advance(world, 0.125, 10.0)
    wrenches.hold(0, 'world', 'world', [2.0, 0.0, 0.0], expires=10.1)
    world.reset()
    cases.advance(world, 0.125, 5.0)
    np.testing.assert_array_equal(world.y[:, LINEAR_MOMENTUM], 0.0)
    assert wrenches.held == {}


def test_same_key_replaces_and_different_keys_add():
    """A wrench held under the key of an earlier one replaces it; under another key it adds."""
    world, wrenches = pushed()
    wrenches.hold(0, 'joystick', 'world', [1.0, 0.0, 0.0], [0.0, 0.5, 0.0])
    wrenches.hold(0, 'joystick', 'world', [0.0, 2.0, 0.0], [0.0, 0.0, 0.3])
    np.testing.assert_array_equal(net_wrench(world)[0], [0.0, 2.0, 0.0])
    np.testing.assert_array_equal(net_wrench(world)[1], [0.0, 0.0, 0.3])
    wrenches.hold(0, 'planner', 'world', [0.0, 0.0, 3.0], [0.1, 0.0, 0.0])
    np.testing.assert_array_equal(net_wrench(world)[0], [0.0, 2.0, 3.0])
    np.testing.assert_array_equal(net_wrench(world)[1], [0.1, 0.0, 0.3])
    force, torque = world.wrench(world.snapshot())
    assert not force[1].any() and not torque[1].any()   # the other body feels nothing


def test_wrench_frames():
    """World axes act as given at the centre of mass.

    Body axes are turned by R; a force at body point p gives the torque (x_p - x) x f with x_p - x
    = R (p - c), in both 'point' (body-axes force) and 'world_point' (world-axes force).
    """
    force, torque, point = np.array([1.0, -2.0, 0.5]), np.array([0.2, 0.1, -0.3]), \
        np.array([0.3, 0.1, -0.2])
    lever = TILT.apply(point - COM)
    expected = {
        'world': (force, torque),
        'body': (TILT.apply(force), TILT.apply(torque)),
        'point': (TILT.apply(force), TILT.apply(torque) + np.cross(lever, TILT.apply(force))),
        'world_point': (force, torque + np.cross(lever, force)),
    }
    for frame, (world_force, world_torque) in expected.items():
        world, wrenches = pushed()
        wrenches.hold(0, 'key', frame, force, torque, point=point)
        np.testing.assert_allclose(net_wrench(world)[0], world_force, atol=1e-15, err_msg=frame)
        np.testing.assert_allclose(net_wrench(world)[1], world_torque, atol=1e-15,
                                   err_msg=frame)


def test_world_point_forces_act_on_their_own_bodies_whatever_order_they_came_in():
    """Forces held at world points on both bodies, interleaved, one replaced and one dropped.

    Each body's torque is the sum over the forces it still holds of R (p - c) x f (its
    world force, the sum of its f), whatever the order the holds came in.
    """
    world, wrenches = pushed()
    holds = [(1, 'a', [1.0, 0.0, 0.0], [0.3, 0.1, -0.2]), (0, 'a', [0.0, 2.0, 0.0], [0.1, 0, 0]),
             (1, 'b', [0.0, 0.0, -1.5], [-0.2, 0.4, 0.1]), (0, 'b', [0.5, 0.5, 0.0], [0, 0, 0.3]),
             (1, 'a', [0.0, -1.0, 0.5], [0.2, 0.2, 0.2])]   # replaces body 1's first
    for body, key, force, point in holds:
        wrenches.hold(body, key, 'world_point', force, point=point)
    wrenches.release(0, 'a')
    held = {(1, 'a'): holds[4], (1, 'b'): holds[2], (0, 'b'): holds[3]}
    force, torque = world.wrench(world.snapshot())
    for body in (0, 1):
        expected_force, expected_torque = np.zeros(3), np.zeros(3)
        for (owner, _), (_, _, f, point) in held.items():
            if owner == body:
                expected_force += f
                expected_torque += np.cross(TILT.apply(np.subtract(point, COM)), f)
        np.testing.assert_allclose(force[body], expected_force, atol=1e-15)
        np.testing.assert_allclose(torque[body], expected_torque, atol=1e-15)


@pytest.mark.parametrize('body, frame, force, torque', [
    (0, 'world', [np.nan, 0.0, 0.0], [0.0, 0.0, 0.0]),
    (0, 'body', [0.0, 0.0, 0.0], [0.0, np.inf, 0.0]),
    (0, 'world', [8.0, 8.0, 0.0], [0.0, 0.0, 0.0]),      # |F| = 11.3 N > 10 N
    (0, 'world', [0.0, 0.0, 0.0], [4.0, 0.0, 4.0]),      # |tau| = 5.7 N m > 5 N m
    (0, 'base_link', [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]),  # not a wrench frame
    (1, 'world', [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]),      # body 1 takes no wrench input
], ids=['nan-force', 'inf-torque', 'force-limit', 'torque-limit', 'unknown-frame',
        'no-input'])
def test_refused_wrench_changes_nothing(body, frame, force, torque):
    """A refused wrench raises ValueError, and what was held stays held.

    Refused: not finite, above the limits, in an unknown frame or aimed at a body without
    wrench input.
    """
    world, wrenches = pushed(accepts=[True, False])
    wrenches.hold(0, 'key', 'world', [1.0, 2.0, 3.0], [0.1, 0.2, 0.3])
    before, wrench_before = wrenches.held, world.wrench(world.snapshot())
    with pytest.raises(ValueError):
        wrenches.hold(body, 'key', frame, force, torque, point=np.zeros(3))
    assert wrenches.held == before
    for after, expected in zip(world.wrench(world.snapshot()), wrench_before):
        np.testing.assert_array_equal(after, expected)


def effect_classes():
    """Every effect class the core ships: the subclasses of Effect in rigid_sim.core.effects."""
    found = set()
    for module in pkgutil.iter_modules(rigid_sim.core.effects.__path__):
        imported = importlib.import_module(f'rigid_sim.core.effects.{module.name}')
        found.update(cls for _, cls in inspect.getmembers(imported, inspect.isclass)
                     if issubclass(cls, Effect) and cls is not Effect)
    return found


@pytest.mark.parametrize('name', sorted(REGISTRY))
def test_unlisted_effects_cost_nothing(name, monkeypatch):
    """A world compiles and runs only the effects it lists.

    With none, no effect's parameters or energy are read while it steps (every effect's are
    made to raise), its wrench sum gets the inputs alone, the net wrench is zero and no body is
    torqued; with gravity alone, gravity's parameters are the only effect's its kernel is given.
    """
    def refuse(*args):
        raise AssertionError('an unlisted effect was evaluated')

    assert {Damping, Gravity, Springs} <= effect_classes()
    for cls in effect_classes():
        monkeypatch.setattr(cls, 'parameters', property(refuse))
        monkeypatch.setattr(cls, 'potential_energy', refuse)
    bare = tumbling(integrator=name)
    assert bare.effects == [] and not bare.torqued.any()
    assert [type(p) for p in bare.effect_parameters()] == [WrenchInputs]
    cases.advance(bare, 0.05, 0.2)
    bare.energy()
    assert not np.any(bare.wrench(bare.snapshot()))
    monkeypatch.undo()
    only_gravity = tumbling(lambda bodies: [Gravity(bodies, GRAVITY)], integrator=name)
    cases.advance(only_gravity, 0.05, 0.2)
    assert [type(effect) for effect in only_gravity.effects] == [Gravity]
    assert [type(p) for p in only_gravity.effect_parameters()] == [GravityParameters,
                                                                   WrenchInputs]
    assert only_gravity.integrator.evaluations > 0


def test_every_effect_is_registered_under_its_scene_key():
    """The registry holds every effect class the core ships, each under its own name."""
    assert set(EFFECTS.values()) == effect_classes()
    assert all(cls.name == name for name, cls in EFFECTS.items())


class Unkernelled(NamedTuple):
    """Parameters no compiled kernel is registered for."""

    weight: np.ndarray


def test_an_effect_without_its_declarations_is_refused_at_registration():
    """An effect a scene could list but no step could evaluate is not registered.

    It must name its scene key, its fields and its parts, and every part needs a kernel.
    """
    unnamed = type('Unnamed', (Effect,), {'parts': (GravityParameters,)})
    with pytest.raises(TypeError, match='Unnamed must declare'):
        registry(unnamed)
    orphan = type('Orphan', (Effect,), {'name': 'orphan', 'scene_fields': raw,
                                        'parts': (Unkernelled,)})
    with pytest.raises(TypeError, match='Orphan: no compiled kernel .* Unkernelled'):
        registry(orphan)
    declared = type('Declared', (Effect,), {'name': 'declared', 'scene_fields': raw,
                                            'parts': (GravityParameters,)})
    assert registry(declared) == {'declared': declared}
