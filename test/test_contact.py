# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Contact against closed forms: sliding, rolling, resting, bouncing, stacking.

Each expected value is the textbook rigid-body result for Coulomb friction and Newton
restitution, derived in the test's own docstring; none comes from the code. Worlds come from
scene mappings, as a user writes them.
"""
import itertools
import math
import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rigid_sim.core.scene import build_world, load_scene, parse_scene, SceneError
from rigid_sim.resources import find_scene

pytestmark = pytest.mark.usefixtures('every_shape_kind')   # one stage compile (conftest)

G = 9.81
L_BLOCK = os.path.join(os.path.dirname(__file__), '..', 'config', 'meshes', 'l_block.obj')
DOWN = [0.0, 0.0, -G]
GROUND = {'normal': [0.0, 0.0, 1.0], 'offset': 0.0}
CAN = {'type': 'cylinder', 'radius': 0.1, 'length': 0.3}
PILL = {'type': 'capsule', 'radius': 0.05, 'length': 0.1}


def contact_world(bodies, dt_free=None, **contact):
    """World of ``bodies`` (scene entries) under gravity with the ground plane(s)."""
    contact.setdefault('planes', [GROUND])
    scene = parse_scene({'effects': {'gravity': {'acceleration': DOWN}, 'contact': contact},
                         'bodies': bodies})
    return build_world(scene)


def body(name, shape, position, linear=(0.0, 0.0, 0.0), angular=(0.0, 0.0, 0.0),
         orientation=(0.0, 0.0, 0.0, 1.0), mass=1.0):
    return {'name': name, 'shape': shape, 'mass': mass,
            'pose': {'position': list(position), 'orientation': list(orientation)},
            'twist': {'linear': list(linear), 'angular': list(angular)}}


def cube(name, edge, position, **kwargs):
    return body(name, {'type': 'box', 'size': [edge] * 3}, position, **kwargs)


def ball(name, radius, position, **kwargs):
    return body(name, {'type': 'sphere', 'radius': radius}, position, **kwargs)


def velocity(world, i=0):
    return world.y[i, 7:10] / world.bodies.mass[i]


@pytest.mark.parametrize('angle', [0.0, 45.0])
def test_box_slides_to_a_stop_after_v0_squared_over_2_mu_g(angle):
    """A block sliding on level ground decelerates at ``mu g``: it stops after ``v0^2/(2 mu g)``.

    The same in every direction (an isotropic cone): at 45 degrees to the contact's
    tangent axes, a pyramidal cone would make friction sqrt(2) stronger.
    """
    mu, v0 = 0.3, 2.0
    direction = np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle)), 0.0])
    world = contact_world([cube('block', 0.2, (0.0, 0.0, 0.1), linear=v0 * direction)],
                          friction=mu)
    start = world.y[0, :3].copy()
    for _ in range(1000):
        world.step(0.001)
    moved = world.y[0, :3] - start
    expected = v0 ** 2 / (2 * mu * G)
    assert np.linalg.norm(velocity(world)) < 1e-9
    assert abs(moved @ direction - expected) < 0.005 * expected
    assert np.linalg.norm(np.cross(moved, direction)) < 1e-6 * expected
    assert abs(moved[2]) < 1e-6


def test_ball_launched_without_spin_rolls_after_2_v0_over_7_mu_g_at_5_v0_over_7():
    """Sliding friction ``mu M g`` slows the centre and spins the ball up until it rolls.

    ``v = v0 - mu g t`` and ``omega r = (5/2) mu g t`` (solid sphere, ``I = 2/5 M r^2``)
    meet at ``t* = 2 v0 / (7 mu g)``, where ``v* = 5 v0 / 7``; then it rolls on at ``v*``.
    """
    mu, v0, r = 0.3, 2.0, 0.1
    world = contact_world([ball('ball', r, (0.0, 0.0, r), linear=(v0, 0.0, 0.0))], friction=mu)
    dt, rolling_at = 1e-4, None
    inertia = 0.4 * r * r
    for k in range(1, 4001):
        world.step(dt)
        spin = world.y[0, 10:13] / inertia
        slip = velocity(world)[0] - spin[1] * r
        if rolling_at is None and abs(slip) < 1e-5 * v0:   # it falls 1e-3 v0 a step
            rolling_at = k * dt
    t_star, v_star = 2 * v0 / (7 * mu * G), 5 * v0 / 7
    assert rolling_at is not None
    assert abs(rolling_at - t_star) < 0.005 * t_star
    assert abs(velocity(world)[0] - v_star) < 0.005 * v_star


def incline(theta):
    """Plane through the origin tilted by ``theta`` about y; returns it and the downhill unit."""
    normal = [-math.sin(theta), 0.0, math.cos(theta)]
    return {'normal': normal, 'offset': 0.0}, -np.array([math.cos(theta), 0.0, math.sin(theta)])


def test_ball_rolls_down_an_incline_at_five_sevenths_g_sin_theta():
    """Rolling without slipping, the ball's acceleration is ``(5/7) g sin(theta)``.

    ``M a = M g sin(theta) - F``, ``I a / r = F r``, so ``a = g sin(theta) / (1 + I / (M
    r^2))``, and ``I = 2/5 M r^2`` for a solid sphere.
    """
    theta, r = math.radians(20.0), 0.1
    plane, downhill = incline(theta)
    normal = np.array(plane['normal'])
    world = contact_world([ball('ball', r, r * normal)], planes=[plane], friction=0.5)
    start = world.y[0, :3].copy()
    steps, dt = 1000, 0.001
    for _ in range(steps):
        world.step(dt)
    t = steps * dt
    expected = 0.5 * (5.0 / 7.0) * G * math.sin(theta) * t * t
    moved = world.y[0, :3] - start
    assert abs(moved @ downhill - expected) < 0.005 * expected
    assert abs(moved @ normal) < 1e-6


def test_box_stays_on_an_incline_flatter_than_its_friction_angle():
    """``tan(theta) < mu``: static friction holds the block; it must not creep (< 1 mm in 10 s)."""
    theta, edge = math.radians(20.0), 0.2
    plane, _ = incline(theta)
    normal = np.array(plane['normal'])
    turn = [0.0, math.sin(-theta / 2), 0.0, math.cos(-theta / 2)]
    world = contact_world([cube('block', edge, 0.5 * edge * normal, orientation=turn)],
                          planes=[plane], friction=0.5)
    start = world.y[0, :3].copy()
    for _ in range(1000):
        world.step(0.01)
    assert np.linalg.norm(world.y[0, :3] - start) < 1e-3


def test_ball_bounces_to_e_squared_heights_and_comes_to_rest_by_the_geometric_sum():
    """Newton's law ``v+ = -e v-`` gives apexes at ``e^(2k) h0``, at rest by the flights' sum.

    The flights last ``t0, 2 e t0, 2 e^2 t0, ...``, ``t0 = sqrt(2 h0 / g)``, summing to
    ``t0 (1 + e) / (1 - e)``; below the resting speed a bounce ends at rest.
    """
    e, r, h0 = 0.8, 0.05, 1.0
    world = contact_world([ball('ball', r, (0.0, 0.0, r + h0))], restitution=e,
                          resting_speed=0.02)
    dt = 1e-4
    t0 = math.sqrt(2 * h0 / G)
    rest_time = t0 * (1 + e) / (1 - e)
    apexes, rising, rested_at = [], False, None
    height = world.y[0, 2] - r
    for k in range(1, int(1.05 * rest_time / dt)):
        world.step(dt)
        v = velocity(world)[2]
        if v > 0.0:
            rising = True
        elif rising:
            apexes.append(world.y[0, 2] - r)
            rising = False
        if rested_at is None and abs(v) < 1e-9 and abs(world.y[0, 2] - r) < 1e-9:
            rested_at = k * dt
        height = world.y[0, 2] - r
    for k, apex in enumerate(apexes[:4], start=1):
        assert abs(apex - e ** (2 * k) * h0) < 0.01 * e ** (2 * k) * h0
    assert rested_at is not None and abs(rested_at - rest_time) < 0.02 * rest_time
    assert abs(height) < 1e-9


def test_stack_of_ten_boxes_stands_still():
    """Ten boxes resting on each other stay: < 0.1 mm drift in 10 s, < 1 mm overlap."""
    edge = 0.2
    boxes = [cube(f'b{k}', edge, (0.0, 0.0, edge * (k + 0.5))) for k in range(10)]
    world = contact_world(boxes, friction=0.6, iterations=200)
    start = world.y[:, :3].copy()
    for _ in range(1000):
        world.step(0.01)
        bottoms = world.y[:, 2] - 0.5 * edge
        gaps = np.diff(np.concatenate([[0.0], bottoms])) - np.r_[0.0, [edge] * 9]
        assert gaps.min() > -1e-3
    assert np.abs(world.y[:, :3] - start).max() < 1e-4


def test_repeat_runs_give_the_same_bits():
    """Contact order is by key, never by detection order: a run repeats to the last bit."""
    pill = body('d', CAN, (-0.05, 0.1, 1.9), angular=(2.0, 0.0, 1.0))
    pill['collision'] = PILL
    bodies = [cube('a', 0.2, (0.0, 0.0, 0.5), angular=(1.0, 2.0, 0.5)),
              ball('b', 0.1, (0.05, 0.02, 0.9), linear=(0.1, 0.0, 0.0)),
              cube('c', 0.3, (0.1, -0.05, 1.4), angular=(0.0, 1.0, 3.0)), pill,
              body('e', CAN, (0.0, 0.05, 2.4), angular=(0.5, 1.5, 0.0))]
    assert_runs_repeat(lambda: contact_world(bodies, restitution=0.3), 300)


def assert_runs_repeat(make_world, steps):
    """Assert a run repeats to the same bits, in a new world and after a reset.

    Two worlds ``make_world()`` makes each run ``steps`` steps twice, reset between.
    """
    runs = []
    for _ in range(2):
        world = make_world()
        for _ in range(2):
            for _ in range(steps):
                world.step(0.01)
            runs.append(world.y.copy())
            world.reset()
    for run in runs[1:]:
        np.testing.assert_array_equal(run, runs[0])


def test_contact_changes_nothing_when_nothing_touches():
    """Bodies in flight: a scene with contact steps to the same bits as one without."""
    bodies = [cube('a', 0.2, (0.0, 0.0, 5.0), angular=(1.0, 2.0, 0.5)),
              ball('b', 0.1, (3.0, 0.0, 5.0), linear=(0.1, 0.0, 0.0))]
    plain = build_world(parse_scene({'effects': {'gravity': {'acceleration': DOWN}},
                                     'bodies': bodies}))
    touching = contact_world(bodies)
    assert plain.contact is None
    for _ in range(50):
        plain.step(0.01)
        touching.step(0.01)
    np.testing.assert_array_equal(plain.y, touching.y)


@pytest.mark.parametrize('contact, key, words', [
    ({'restitution': 1.5}, 'effects.contact.restitution', 'at most 1'),
    ({'planes': [{'normal': [0.0, 0.0, 0.0]}]}, 'effects.contact.planes[0].normal', 'zero'),
    ({'friction': -0.1}, 'effects.contact.friction', 'non-negative'),
    ({'iterations': 0}, 'effects.contact.iterations', 'positive'),
])
def test_bad_contact_settings_are_refused_by_key(contact, key, words):
    with pytest.raises(SceneError) as refused:
        parse_scene({'effects': {'contact': contact},
                     'bodies': [ball('b', 0.1, (0.0, 0.0, 1.0))]})
    assert refused.value.key == key and words in refused.value.reason


def test_a_mesh_needs_a_collision_shape_in_a_scene_with_contact():
    mesh = body('m', {'type': 'mesh', 'file': L_BLOCK}, (0.0, 0.0, 1.0))
    with pytest.raises(SceneError) as refused:
        parse_scene({'effects': {'contact': {}}, 'bodies': [mesh]})
    assert refused.value.key == 'bodies[0].collision' and 'mesh' in refused.value.reason
    mesh['collision'] = {'type': 'box', 'size': [0.2, 0.2, 0.3]}
    world = build_world(parse_scene({'effects': {'gravity': {'acceleration': DOWN},
                                                 'contact': {'planes': [GROUND]}},
                                     'bodies': [mesh]}))
    for _ in range(200):
        world.step(0.01)
    # The box is centred on the body frame, off the mass centre: it tips onto a face.
    turn = Rotation.from_quat(world.y[0, 3:7])
    origin = world.y[0, :3] - turn.apply(world.bodies.com_in_body[0])
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    corners = origin + turn.apply(signs * [0.1, 0.1, 0.15])
    assert abs(corners[:, 2].min()) < 1e-6


# Body z along world y: a cylinder or capsule lying on its side, its axis across the x slope.
ON_SIDE = [-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)]


def test_cylinder_standing_on_a_cap_rests():
    """A cylinder on a cap collides as its shape by default; it must not creep (< 1 mm in 2 s)."""
    world = contact_world([body('can', CAN, (0.0, 0.0, 0.15))], friction=0.5)
    start = world.y[0, :7].copy()
    for _ in range(200):
        world.step(0.01)
    assert np.abs(world.y[0, :3] - start[:3]).max() < 1e-3
    assert np.abs(world.y[0, 3:7] - start[3:7]).max() < 1e-6


def test_cylinder_rolls_down_an_incline_at_g_sin_theta_over_1_plus_i_over_m_r2():
    """Rolling without slipping: ``M a = M g sin(theta) - F``, ``I a / r = F r``.

    So ``a = g sin(theta) / (1 + I / (M r^2))``, with ``I`` the body's own inertia about its
    axis (``M r^2 / 2`` for a solid cylinder: ``a = (2/3) g sin(theta)``).
    """
    theta, r = math.radians(20.0), CAN['radius']
    plane, downhill = incline(theta)
    normal = np.array(plane['normal'])
    world = contact_world([body('can', CAN, r * normal, orientation=ON_SIDE, mass=2.0)],
                          planes=[plane], friction=0.5)
    inertia = world.bodies.inertia_body[0, 2, 2]
    start = world.y[0, :3].copy()
    steps, dt = 1000, 0.001
    for _ in range(steps):
        world.step(dt)
    t = steps * dt
    a = G * math.sin(theta) / (1.0 + inertia / (2.0 * r * r))
    moved = world.y[0, :3] - start
    expected = 0.5 * a * t * t
    assert abs(moved @ downhill - expected) < 0.005 * expected
    assert abs(moved @ normal) < 1e-6
    assert abs(moved[1]) < 1e-6   # along its axis: no drift


def test_capsule_lying_on_its_side_stays():
    """A capsule on the ground rests on its two end spheres: no motion in 10 s."""
    capsule = body('pill', CAN, (0.0, 0.0, 0.1), orientation=ON_SIDE)
    capsule['collision'] = {'type': 'capsule', 'radius': 0.1, 'length': 0.3}
    world = contact_world([capsule])
    start = world.y[0, :7].copy()
    for _ in range(1000):
        world.step(0.01)
    assert np.abs(world.y[0, :7] - start).max() < 1e-6
    assert world.contact.count == 2


@pytest.mark.parametrize('bodies', [
    [cube('table', 0.4, (0.0, 0.0, 0.2), mass=5.0), body('can', CAN, (0.05, 0.02, 0.55))],
    [cube('table', 0.4, (0.0, 0.0, 0.2), mass=5.0),
     body('can', CAN, (0.0, 0.0, 0.5), orientation=ON_SIDE)],
    [body('lower', CAN, (0.0, 0.0, 0.15)), body('upper', CAN, (0.03, 0.0, 0.45))],
    [body('can', CAN, (0.0, 0.0, 0.15)), cube('lid', 0.1, (0.0, 0.0, 0.35))],
    [body('can', CAN, (0.0, 0.0, 0.15)),
     dict(body('pill', CAN, (0.0, 0.0, 0.35), orientation=ON_SIDE), collision=PILL)],
], ids=['can on a box', 'can on its side on a box', 'can on a can', 'box on a can',
        'capsule on a can'])
def test_cylinder_pairs_through_support_mappings_rest(bodies):
    """Resting on a cylinder, or a cylinder resting on a box: no motion (< 1 mm in 2 s).

    These pairs go through GJK/EPA and each shape's own points (rim points, corners, end
    spheres) against the other's distance: a flat face must rest on a patch, not rock on the
    one deepest point.
    """
    world = contact_world(bodies, friction=0.6, iterations=100)
    start = world.y[:, :7].copy()
    for _ in range(200):
        world.step(0.01)
    assert np.abs(world.y[:, :7] - start).max() < 1e-3


def test_capsule_lying_on_a_box_stays_on_two_contacts():
    """A capsule on a box's top face: the segment clipped to the face gives two contacts.

    It must rest there (no motion in 5 s), held at its two ends, not balanced on one point.
    """
    capsule = body('pill', CAN, (0.0, 0.0, 0.45), orientation=ON_SIDE)
    capsule['collision'] = {'type': 'capsule', 'radius': 0.05, 'length': 0.2}
    world = contact_world([cube('table', 0.4, (0.0, 0.0, 0.2), mass=5.0), capsule],
                          friction=0.6)
    start = world.y[:, :7].copy()
    for _ in range(500):
        world.step(0.01)
    assert np.abs(world.y[:, :7] - start).max() < 1e-6
    bodies, points, _, _ = world.contact.contacts()
    on_box = points[(bodies[:, 0] == 0) & (bodies[:, 1] == 1)]
    assert len(on_box) == 2
    np.testing.assert_allclose(np.sort(on_box[:, 1]), [-0.1, 0.1], atol=1e-9)


def test_the_packaged_contact_scene_does_what_its_comment_says():
    """The packaged contact.yaml: bounce, slide, stack as its comment says, then rest.

    The ball's first rebound reaches ``e^2 h0 = 0.25 m``, the slider stops after
    ``v^2 / (2 mu g)``, the boxes end stacked.
    """
    world = build_world(load_scene(find_scene('contact.yaml')))
    names = world.bodies.names
    chosen = ('ball', 'top_box', 'bottom_box', 'slider')
    ball, top, bottom, slider = (names.index(name) for name in chosen)
    start = world.y[slider, 0]
    apex, falling_again, dt = 0.0, False, 1e-3
    for _ in range(5000):
        world.step(dt)
        if velocity(world, ball)[2] > 0.0:
            apex = max(apex, world.y[ball, 2] - 0.1)
            falling_again = True
        elif falling_again:
            break
    assert abs(apex - 0.25) < 0.01 * 0.25
    for _ in range(3000):
        world.step(dt)
    assert abs(world.y[slider, 0] - start - 2.0 ** 2 / (2 * 0.4 * G)) < 0.005
    assert abs(world.y[top, 2] - 0.3) < 1e-3 and abs(world.y[bottom, 2] - 0.1) < 1e-3
    assert np.abs(world.y[:, 7:13]).max() < 1e-6


def test_warm_up_compiles_the_contact_stage_and_changes_nothing():
    """The node warms a world up before it ticks: contact's kernel is among those compiled."""
    from rigid_sim.core.warm_up import warm_up
    world = contact_world([cube('a', 0.2, (0.0, 0.0, 0.1))])
    for _ in range(3):
        world.step(0.01)
    before = (world.y.copy(), world.contact.work.last_lam.copy(), world.contact.count)
    warm_up(world)
    np.testing.assert_array_equal(world.y, before[0])
    np.testing.assert_array_equal(world.contact.work.last_lam, before[1])
    assert world.contact.count == before[2] == 4
    assert world.contact.work.last_count[0] == 4


def test_a_scenes_own_stage_steps_as_the_stage_of_every_kind(monkeypatch):
    """The stage compiled for a scene's kinds alone gives the bits of the one for all kinds."""
    bodies = [cube('a', 0.2, (0.0, 0.0, 0.5), angular=(1.0, 2.0, 0.5)),
              ball('b', 0.1, (0.05, 0.02, 0.9), linear=(0.1, 0.0, 0.0)),
              cube('c', 0.3, (0.1, -0.05, 1.4), angular=(0.0, 1.0, 3.0))]
    runs = []
    for _ in range(2):
        world = contact_world(bodies, restitution=0.3)
        for _ in range(300):
            world.step(0.01)
        runs.append(world.y.copy())
        monkeypatch.undo()   # the scene's own kinds from here on: spheres and boxes
    np.testing.assert_array_equal(runs[1], runs[0])
