# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Contact in exact mode against closed forms: impacts struck at the moment they happen.

Every expected value is Newton's restitution and Coulomb's friction on free flight, derived
in the test's docstring; the measured impact times and apexes are read off the state by
projectile motion (the oracle :func:`last_impact`), never from the code's own events.
"""
import math

import numpy as np
import pytest

from rigid_sim.core.scene import build_world, parse_scene, SceneError
from test_contact import assert_runs_repeat

pytestmark = pytest.mark.usefixtures('every_shape_kind')   # one stage compile (conftest)

G = 9.81
GROUND = {'normal': [0.0, 0.0, 1.0], 'offset': 0.0}
E, H0 = 0.8, 1.0


def exact_world(bodies, integrator='exact_split', gravity=True, **contact):
    """World of scene ``bodies`` in exact mode, on the ground unless ``planes`` says else."""
    contact.setdefault('planes', [GROUND])
    effects = {'contact': {'mode': 'exact', **contact}}
    if gravity:
        effects['gravity'] = {'acceleration': [0.0, 0.0, -G]}
    return build_world(parse_scene({'effects': effects, 'bodies': bodies}),
                       integrator=integrator)


def body(name, shape, position, linear=(0.0, 0.0, 0.0)):
    return {'name': name, 'shape': shape, 'mass': 1.0, 'pose': {'position': list(position)},
            'twist': {'linear': list(linear)}}


def last_impact(now, height, speed):
    """Time and apex of the flight a body rising at ``speed`` at ``height`` is in.

    Free flight since an impact at height 0: ``height = u s - g s^2 / 2`` and ``speed =
    u - g s`` give the time ``s`` since it; the apex is ``height + speed^2 / (2 g)``.
    """
    since = (-speed + math.sqrt(speed * speed + 2.0 * G * height)) / G
    return now - since, height + speed * speed / (2.0 * G)


def bounce(world, bottom, dt, duration):
    """Impact times, apexes and the time at rest of body 0, ``bottom`` m under its centre.

    An impact shows as the vertical speed turning from falling to rising between steps.
    """
    impacts, apexes, falling, rested = [], [], True, None
    for k in range(1, int(round(duration / dt)) + 1):
        world.step(dt)
        height, speed = world.y[0, 2] - bottom, world.y[0, 9] / world.bodies.mass[0]
        if speed > 0.0 and falling:
            impact, apex = last_impact(k * dt, height, speed)
            impacts.append(impact)
            apexes.append(apex)
        falling = speed <= 0.0
        if rested is None and abs(speed) < 1e-9 and abs(height) < 1e-9:
            rested = k * dt
    return impacts, apexes, rested


def expected_impacts(count):
    """``t_1 = t0``, then flights of ``2 e^k t0``: ``t_k = t0 (1 + 2 e (1 - e^(k-1))/(1 - e))``.

    ``t0 = sqrt(2 h0 / g)`` is the fall from ``h0``; the k-th rebound leaves at ``e^k v0``.
    """
    t0 = math.sqrt(2.0 * H0 / G)
    return [t0 * (1.0 + 2.0 * E * (1.0 - E ** (k - 1)) / (1.0 - E)) for k in range(1, count + 1)]


SHAPES = {
    'ball': ({'type': 'sphere', 'radius': 0.05}, 0.05),
    'flat box': ({'type': 'box', 'size': [0.3, 0.2, 0.1]}, 0.05),
}


@pytest.mark.parametrize('integrator', ['exact_split', 'rk4'])
@pytest.mark.parametrize('shape', SHAPES)
def test_drop_bounces_at_the_closed_form_times_to_e_to_the_2k_heights(shape, integrator):
    """Apexes ``e^(2k) h0`` and impact times ``t_k`` to 1e-6; at rest by ``t0 (1+e)/(1-e)``.

    The flights sum to ``t0 (1 + 2e + 2e^2 + ...) = t0 (1 + e) / (1 - e)``; a rebound
    slower than the resting speed ends at rest, which cuts the sum's tail of about
    ``2 v_rest / (g (1 - e))`` = 0.02 s. A box dropped flat strikes with its four lower
    corners at once and bounces as the ball does.
    """
    collision, bottom = SHAPES[shape]
    world = exact_world([body('b', collision, (0.0, 0.0, bottom + H0))], integrator,
                        restitution=E, resting_speed=0.02)
    rest_time = math.sqrt(2.0 * H0 / G) * (1.0 + E) / (1.0 - E)
    impacts, apexes, rested = bounce(world, bottom, 1e-3, 1.05 * rest_time)
    for k, (impact, expected) in enumerate(zip(impacts[:6], expected_impacts(6)), start=1):
        assert abs(impact - expected) < 1e-6 * expected
        assert abs(apexes[k - 1] - E ** (2 * k) * H0) < 1e-6 * E ** (2 * k) * H0
    assert rested is not None and abs(rested - rest_time) < 0.02 * rest_time
    assert abs(world.y[0, 2] - bottom) < 1e-9 and np.abs(world.y[0, 7:13]).max() < 1e-9


@pytest.mark.parametrize('dt', [0.01, 1.0 / 60.0])
def test_impacts_do_not_depend_on_the_step(dt):
    """At a node's tick of 10 ms or 1/60 s the impacts are as exact: they fall between ends."""
    world = exact_world([body('b', SHAPES['ball'][0], (0.0, 0.0, 0.05 + H0))],
                        restitution=E, resting_speed=0.2)
    impacts, apexes, _ = bounce(world, 0.05, dt, 6.0)
    for k, (impact, expected) in enumerate(zip(impacts[:6], expected_impacts(6)), start=1):
        assert abs(impact - expected) < 1e-6 * expected
        assert abs(apexes[k - 1] - E ** (2 * k) * H0) < 1e-6 * E ** (2 * k) * H0


def test_ball_thrown_sideways_slides_through_its_impact_as_coulomb_says():
    """An impact that slides throughout: ``dv_x = -mu (1 + e) v_n``, ``omega r = (5/2) |dv_x|``.

    The normal impulse is ``M (1 + e) v_n``; friction ``mu`` times it opposes the slip while
    ``mu (1 + e) v_n < (2/7) v_x`` (what would stop the slip of a solid sphere, ``I =
    (2/5) M r^2``). The ball flies at ``v_x`` before: it strikes at ``x = v_x t0``.
    """
    mu, vx, r = 0.1, 5.0, 0.05
    world = exact_world([body('b', {'type': 'sphere', 'radius': r}, (0.0, 0.0, r + H0),
                              linear=(vx, 0.0, 0.0))], restitution=E, friction=mu)
    t0, vn = math.sqrt(2.0 * H0 / G), math.sqrt(2.0 * G * H0)
    dt = 1e-3
    steps = int(t0 / dt) + 50   # past the first impact, before the second
    for _ in range(steps):
        world.step(dt)
    after = vx - mu * (1.0 + E) * vn
    assert mu * (1.0 + E) * vn < 2.0 / 7.0 * vx   # it slides throughout
    assert abs(world.y[0, 7] - after) < 1e-9 * vx
    spin = world.y[0, 11] / (0.4 * r * r)
    assert abs(spin * r - 2.5 * mu * (1.0 + E) * vn) < 1e-9 * vx
    # Back along the flight since the impact, to where it struck.
    impact, apex = last_impact(steps * dt, world.y[0, 2] - r, world.y[0, 9])
    assert abs(impact - t0) < 1e-9 * t0 and abs(apex - E * E * H0) < 1e-9
    assert abs(world.y[0, 0] - (vx * t0 + after * (steps * dt - t0))) < 1e-9


@pytest.mark.parametrize('shape', [{'type': 'sphere', 'radius': 0.1},
                                   {'type': 'box', 'size': [0.2, 0.2, 0.2]}])
def test_pair_meets_head_on_at_the_closed_form_time(shape):
    """Equal bodies closing at ``2 v`` across a gap ``d`` meet at ``d / (2 v)``, leave at ``e v``.

    No gravity; the step (0.03 s) does not divide the meeting time (0.4 s).
    """
    e, v, dt = 0.5, 1.0, 0.03
    world = exact_world([body('a', shape, (-0.5, 0.0, 0.0), linear=(v, 0.0, 0.0)),
                         body('b', shape, (0.5, 0.0, 0.0), linear=(-v, 0.0, 0.0))],
                        gravity=False, planes=[], restitution=e)
    meet = (1.0 - 0.2) / (2.0 * v)
    steps = 34
    for _ in range(steps):
        world.step(dt)
    after = steps * dt - meet
    np.testing.assert_allclose(world.y[:, 7], [-e * v, e * v], rtol=1e-12)
    expected = -0.5 + v * meet - e * v * after
    np.testing.assert_allclose(world.y[:, 0], [expected, -expected], atol=1e-12)
    assert np.abs(world.y[:, 10:13]).max() < 1e-12   # struck head on: no spin


def test_exact_runs_repeat_to_the_same_bits():
    """Root finding and the strikes depend on the state alone: a run repeats bit for bit."""
    bodies = [body('a', {'type': 'box', 'size': [0.2, 0.2, 0.2]}, (0.0, 0.0, 0.5)),
              body('b', {'type': 'sphere', 'radius': 0.1}, (0.05, 0.02, 0.9), (0.1, 0.0, 0.0)),
              body('c', {'type': 'box', 'size': [0.3, 0.3, 0.3]}, (0.1, -0.05, 1.4))]
    assert_runs_repeat(lambda: exact_world(bodies, restitution=0.6), 200)


def test_an_unknown_mode_is_refused_by_key():
    with pytest.raises(SceneError) as refused:
        parse_scene({'effects': {'contact': {'mode': 'exactly'}},
                     'bodies': [body('b', {'type': 'sphere', 'radius': 0.1}, (0, 0, 1))]})
    assert refused.value.key == 'effects.contact.mode'
    assert "'velocity', 'exact'" in refused.value.reason


@pytest.mark.parametrize('kind', ['capsule', 'cylinder'])
def test_exact_mode_refuses_shapes_it_has_no_impact_gap_for(kind):
    """Impacts are found on the gap of spheres and boxes: no other shape is run as a box."""
    pill = dict(body('p', {'type': 'cylinder', 'radius': 0.1, 'length': 0.3}, (0, 0, 1)),
                collision={'type': kind, 'radius': 0.1, 'length': 0.3})
    with pytest.raises(SceneError) as refused:
        parse_scene({'effects': {'contact': {'mode': 'exact'}}, 'bodies': [pill]})
    assert refused.value.key == 'bodies[0].collision'
    assert kind in refused.value.reason and 'velocity' in refused.value.reason
    parse_scene({'effects': {'contact': {'mode': 'velocity'}}, 'bodies': [pill]})


def test_the_stage_reads_the_checks_detection_to_the_bits_of_its_own():
    """The stage after a check that struck nothing ends where detecting again would.

    A step's check keeps its detection of the state the step ended at for the velocity-level
    stage. A twin stage (the same warm start) that detects that state itself must end at the
    same bits; a state changed after the check (a ball lifted off its box) is detected anew.
    """
    bodies = [body('box', {'type': 'box', 'size': [0.2, 0.2, 0.2]}, (0.0, 0.0, 0.1)),
              body('ball', {'type': 'sphere', 'radius': 0.1}, (0.0, 0.0, 0.3)),
              body('slider', {'type': 'box', 'size': [0.2, 0.2, 0.2]}, (1.0, 0.0, 0.1),
                   (0.5, 0.0, 0.0))]
    world = exact_world(bodies, restitution=0.6, friction=0.2)
    for _ in range(20):
        world.step(0.01)
    y, model = world.y.copy(), world.bodies.model
    ends = {}
    for name, lift in (('same', 0.0), ('lifted', 1e-3)):
        kept, own = world.contact.duplicate(), world.contact.duplicate()
        assert kept.struck(y, y, model) == 0 and kept.work.reuse[0] == 1
        end = y.copy()
        end[1, 2] += lift
        own_end = end.copy()
        found = kept.resolve(end, 0.01, model)
        assert found == own.resolve(own_end, 0.01, model)
        np.testing.assert_array_equal(end, own_end)
        np.testing.assert_array_equal(kept.work.last_lam[:found], own.work.last_lam[:found])
        assert kept.work.reuse[0] == 0   # read once
        ends[name] = found
    assert ends['lifted'] == ends['same'] - 1   # the ball's one contact with the box is gone


def test_warm_up_compiles_exact_mode_and_changes_nothing():
    """The node warms a world up before it ticks: exact mode's kernels are among those."""
    from rigid_sim.core.warm_up import warm_up
    world = exact_world([body('b', SHAPES['flat box'][0], (0.0, 0.0, 0.05))])
    for _ in range(3):
        world.step(0.01)
    before = world.y.copy(), world.contact.work.last_lam.copy()
    warm_up(world)
    np.testing.assert_array_equal(world.y, before[0])
    np.testing.assert_array_equal(world.contact.work.last_lam, before[1])


def test_ball_onto_a_box_resting_on_the_ground_bounces_as_off_the_ground():
    """The box rests: the ball's apexes above its top are ``e^(2k) h0``, within the sink.

    Within a step the integrator lets the resting box sink under gravity until the
    velocity-level stage lifts it back at the step's end, at most ``g dt^2 / 2``: each
    impact can come that much lower, so the k-th apex is within ``k g dt^2 / 2``. The box
    is stopped before the impact is solved, so the ball leaves at ``e`` times its own speed.
    """
    h0, dt, top = 0.5, 1e-3, 0.2
    world = exact_world([body('ball', {'type': 'sphere', 'radius': 0.05},
                              (0.0, 0.0, top + 0.05 + h0)),
                         body('box', {'type': 'box', 'size': [0.4, 0.4, top]},
                              (0.0, 0.0, top / 2))], restitution=E, resting_speed=0.02)
    _, apexes, _ = bounce(world, top + 0.05, dt, 2.5)
    for k, apex in enumerate(apexes[:5], start=1):
        assert abs(apex - E ** (2 * k) * h0) < k * G * dt * dt / 2
    np.testing.assert_allclose(world.y[1, :3], [0.0, 0.0, top / 2], atol=1e-9)
