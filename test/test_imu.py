# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The IMU: oracles from rigid-body kinematics, noise statistics, and the topic over ROS.

Specific force is what an accelerometer measures, f = a - g at its point, in its axes;
the oracles: free fall reads 0, a body held up by m g reads +g along world up, a spin
omega about a principal axis reads omega^2 r towards the axis at distance r, a torque tau
on a body at rest reads alpha x r with alpha = I^-1 tau.
"""
import math
import re
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation
from geometry_msgs.msg import WrenchStamped
from sensor_msgs.msg import Imu, MagneticField

import ros_tools

from rigid_sim import conversions
from rigid_sim.core.imu import build_imus, scene_imus
from rigid_sim.core.scene import SceneError, build_world, parse_scene
from rigid_sim.inputs import held_wrenches

G = np.array([0.0, 0.0, -9.81])   # m/s^2
MASS, SIZE = 2.0, np.array([0.4, 0.2, 0.1])
BOX_INERTIA = MASS / 12 * np.array([SIZE[1] ** 2 + SIZE[2] ** 2, SIZE[0] ** 2 + SIZE[2] ** 2,
                                    SIZE[0] ** 2 + SIZE[1] ** 2])
TILT = Rotation.from_rotvec([0.4, -0.7, 1.1])
OFFSET = np.array([0.15, -0.05, 0.02])   # m, body frame: the IMU's point, off the centre


def scene(imu='{point: [0.15, -0.05, 0.02]}', gravity=True, twist='{}', extra='', field=''):
    effects = f'effects: {{gravity: {{acceleration: {G.tolist()}}}}}\n' if gravity else ''
    return parse_scene(yaml.safe_load(f"""
{effects}{field}bodies:
  - name: box
    shape: {{type: box, size: {SIZE.tolist()}}}
    mass: {MASS}
    pose: {{position: [0.0, 0.0, 1.0], orientation: {TILT.as_quat().tolist()}}}
    twist: {twist}
    imu: {imu}
{extra}"""))


def read(scene, steps=0, dt=1e-3, hold=None):
    world = build_world(scene, 'rk4')
    if hold is not None:
        held_wrenches(world).hold(0, 'test', *hold)
    for _ in range(steps):
        assert world.step(dt)
    imus = scene_imus(scene, world)   # gravity: the world's Gravity effect's
    return world, imus.read(world, imus.due(world.time))


def test_free_fall_reads_no_specific_force_and_no_rotation():
    world, readings = read(scene(), steps=50)
    np.testing.assert_allclose(readings.specific_force[0], 0.0, atol=1e-12)
    np.testing.assert_allclose(readings.angular_velocity[0], 0.0, atol=1e-15)
    np.testing.assert_allclose(readings.orientation[0], world.y[0, 3:7])


def test_body_held_up_by_its_weight_reads_g_along_world_up_in_its_own_axes():
    """F = -M g at the centre of mass: a = 0, so f = -g = (0, 0, 9.81) world, R^T of it."""
    world, readings = read(scene(), steps=20, hold=('world', -MASS * G, np.zeros(3), None))
    up_in_body = TILT.inv().apply([0.0, 0.0, 9.81])
    np.testing.assert_allclose(readings.specific_force[0], up_in_body, atol=1e-12)


def test_spin_about_a_principal_axis_reads_centripetal_towards_the_axis():
    """A steady spin about a principal axis reads a centripetal force towards it.

    At omega = 5 rad/s about body z and an IMU at r = (0.15, -0.05, 0.02):
    f = -omega^2 (x, y, 0), and the gyro reads (0, 0, 5) in body axes, at any time.
    """
    omega = 5.0
    spin = TILT.apply([0.0, 0.0, omega]).tolist()
    _, readings = read(scene(gravity=False, twist=f'{{angular: {spin}}}'), steps=37)
    np.testing.assert_allclose(readings.angular_velocity[0], [0.0, 0.0, omega], atol=1e-12)
    np.testing.assert_allclose(readings.specific_force[0],
                               -omega ** 2 * np.array([OFFSET[0], OFFSET[1], 0.0]), atol=1e-11)


def test_torque_on_a_body_at_rest_reads_the_tangential_alpha_cross_r():
    """Body torque tau at rest: alpha = I^-1 tau (no omega yet), f = alpha x r, gyro 0."""
    torque = np.array([0.02, -0.05, 0.01])
    _, readings = read(scene(gravity=False),
                       hold=('body', np.zeros(3), torque, None))
    alpha = torque / BOX_INERTIA
    np.testing.assert_allclose(readings.specific_force[0], np.cross(alpha, OFFSET), atol=1e-13)
    np.testing.assert_allclose(readings.angular_velocity[0], 0.0, atol=0)


def test_named_point_and_readings_on_the_imu_grid_of_simulated_time():
    """An IMU at a named point reads on the grid of its rate in simulated time.

    At 25 Hz, ticked at 1/64 s, it reads at the first tick at or after each multiple of
    0.04 s (t = 0, 3/64, 6/64, 8/64, ...), not at every tick.
    """
    spec = scene('{point: tip, rate: 25.0}', extra='    points: {tip: [0.2, 0.0, 0.0]}')
    world = build_world(spec, 'rk4')
    imus = build_imus(spec.bodies, world.bodies, None)
    assert imus.specs[0].frame == 'tip'
    read_at = [k for k in range(20) if imus.due(k / 64)]
    expected = sorted({math.ceil(n * 0.04 * 64 - 1e-9) for n in range(20)
                       if n * 0.04 < 20 / 64})
    assert read_at == expected


GYRO_ACCEL = ('gyro: {stddev: 0.01, bias_mean: 0.2, bias_stddev: 0.0}, '
              'accel: {stddev: 0.0, dynamic_bias_stddev: 0.3}')
NOISY = '{point: [0.0, 0.0, 0.0], seed: %d, noise: {' + GYRO_ACCEL + '}}'


def noisy_readings(seed, count, dt):
    """``count`` readings at intervals ``dt`` of a body at rest, no gravity: exact is 0."""
    spec = scene(NOISY % seed, gravity=False)
    world = build_world(spec, 'rk4')
    imus = build_imus(spec.bodies, world.bodies, None)
    gyro, accel = [], []
    for k in range(count):
        at = SimpleNamespace(y=world.y, time=k * dt, net_wrench=world.net_wrench)
        readings = imus.read(at, [0])
        gyro.append(readings.angular_velocity[0].copy())
        accel.append(readings.specific_force[0].copy())
    return np.array(gyro), np.array(accel)


def test_white_noise_has_its_mean_and_standard_deviation_within_sampling_bounds():
    """Gyro white noise has the mean and standard deviation of its model.

    Over 4000 x 3 samples of N(0.2, 0.01^2), the mean lies within 5 standard errors of 0.2
    and the sample standard deviation within 5 of its standard errors (sigma / sqrt(2 n)).
    """
    gyro, _ = noisy_readings(seed=1, count=4000, dt=0.01)
    n = gyro.size
    assert abs(gyro.mean() - 0.2) < 5 * 0.01 / math.sqrt(n)
    assert abs(gyro.std(ddof=1) - 0.01) < 5 * 0.01 / math.sqrt(2 * n)


def test_bias_random_walk_grows_as_sigma_squared_t():
    """The bias of a random walk of density 0.3 / sqrt(s) has variance 0.09 t.

    Across 200 seeds x 3 axes, within 5 standard errors (chi-square: var sqrt(2 / n)).
    """
    runs = np.array([noisy_readings(seed, count=41, dt=0.05)[1] for seed in range(200)])
    for k, t in ((10, 0.5), (40, 2.0)):
        values = runs[:, k].ravel()
        expected = 0.09 * t
        assert abs(values.var() - expected) < 5 * expected * math.sqrt(2 / values.size)
        assert abs(values.mean()) < 5 * math.sqrt(expected / values.size)


def test_same_seed_same_noise_other_seed_other_noise():
    first, second = noisy_readings(7, 30, 0.01), noisy_readings(7, 30, 0.01)
    np.testing.assert_array_equal(first[0], second[0])
    np.testing.assert_array_equal(first[1], second[1])
    assert not np.array_equal(first[0], noisy_readings(8, 30, 0.01)[0])


@pytest.mark.parametrize('imu, key, reason', [
    ('{point: nowhere}', 'bodies[0].imu.point', "no point named 'nowhere'"),
    ('{rate: -1.0}', 'bodies[0].imu.rate', 'positive'),
    ('{seed: -3}', 'bodies[0].imu.seed', '>= 0'),
    ('{seed: 1180591620717411303424}', 'bodies[0].imu.seed', 'at most 1e+15'),   # 2**70
    ('{noise: {gyro: {stdev: 0.1}}}', 'bodies[0].imu.noise.gyro.stdev', 'unknown key'),
    ('{noise: {accel: {stddev: -0.1}}}', 'bodies[0].imu.noise.accel.stddev', 'non-negative'),
    ('{orientation: 0}', 'bodies[0].imu.orientation', 'true or false'),
    ('{magnetometer: true}', 'bodies[0].imu.magnetometer', 'no magnetic_field'),
    ('{noise: {mag: {stddev: 1.0e-7}}}', 'bodies[0].imu.noise.mag', 'magnetometer: true'),
    ('[]', 'bodies[0].imu', 'non-empty list'),
    ('[{point: [0, 0, 0]}, {point: [0.1, 0, 0]}]', 'bodies[0].imu[1].name',
     "duplicate IMU name 'imu' (also bodies[0].imu[0])"),
    ('[{name: a}, {name: odom}]', 'bodies[0].imu[1].name', "'odom' is the topic"),
    ('{name: tip, point: [0.1, 0.0, 0.0]}', 'bodies[0].imu.point', "point named 'tip'"),
])
def test_bad_imu_entries_are_refused_naming_the_key(imu, key, reason):
    with pytest.raises(SceneError) as refused:
        scene(imu, extra='    points: {tip: [0.2, 0.0, 0.0]}')
    assert refused.value.key == key and reason in refused.value.reason


FIELD = np.array([2.1e-5, -0.4e-5, -4.3e-5])   # T, world axes, about the Earth's
MAGNETIC = f'magnetic_field: [{", ".join(f"{b:.2e}" for b in FIELD)}]\n'   # 1.0e-5: floats


def test_magnetometer_reads_the_field_in_the_body_axes_as_the_body_turns():
    """A body turned by TILT reads R^T B; spun at omega about a principal axis it reads R(t)^T B.

    The spin about body z is torque-free and steady: R(t) = TILT exp(omega t z).
    """
    omega, steps, dt = 3.0, 40, 1e-3
    spin = TILT.apply([0.0, 0.0, omega]).tolist()
    spec = scene('{magnetometer: true}', gravity=False, twist=f'{{angular: {spin}}}',
                 extra='', field=MAGNETIC)
    world = build_world(spec, 'rk4')
    imus = build_imus(spec.bodies, world.bodies, None, spec.magnetic_field)
    np.testing.assert_allclose(imus.read(world, [0]).magnetic_field[0],
                               TILT.inv().apply(FIELD), rtol=0, atol=1e-18)
    for _ in range(steps):
        assert world.step(dt)
    turned = TILT * Rotation.from_rotvec([0.0, 0.0, omega * steps * dt])
    np.testing.assert_allclose(imus.read(world, [0]).magnetic_field[0],
                               turned.inv().apply(FIELD), rtol=0, atol=1e-15)


def test_magnetometer_noise_has_its_mean_and_spread_and_leaves_the_other_streams_alone():
    """Magnetometer white noise N(bias, sigma^2) within sampling bounds, as the gyro's.

    Adding a magnetometer draws from a stream of its own: the gyro and accelerometer read
    bit for bit what they read without it.
    """
    sigma, bias = 2.0e-7, 5.0e-7
    spec = scene('{point: [0.0, 0.0, 0.0], seed: 1, magnetometer: true, noise: {'
                 f'{GYRO_ACCEL}, mag: {{stddev: {sigma:.1e}, bias_mean: {bias:.1e}}}}}}}',
                 gravity=False, field=MAGNETIC)
    world = build_world(spec, 'rk4')
    imus = build_imus(spec.bodies, world.bodies, None, spec.magnetic_field)
    exact = TILT.inv().apply(FIELD)
    fields, gyro = [], []
    for k in range(4000):
        readings = imus.read(SimpleNamespace(y=world.y, time=k * 0.01,
                                             net_wrench=world.net_wrench), [0])
        fields.append(readings.magnetic_field[0] - exact)
        gyro.append(readings.angular_velocity[0].copy())
    errors = np.array(fields)
    n = errors.size
    assert abs(errors.mean() - bias) < 5 * sigma / math.sqrt(n)
    assert abs(errors.std(ddof=1) - sigma) < 5 * sigma / math.sqrt(2 * n)
    np.testing.assert_array_equal(np.array(gyro), noisy_readings(1, 4000, 0.01)[0])


def test_imus_of_a_list_read_at_their_own_points_and_draw_their_own_noise():
    """Two IMUs on one spinning body read -omega^2 (x, y, 0) each at its own point.

    With the same seed and noise they still draw independent noise: the first draws what a
    single IMU of that seed draws, the second something else.
    """
    omega = 5.0
    spin = TILT.apply([0.0, 0.0, omega]).tolist()
    spec = scene('[{point: [0.15, -0.05, 0.02]}, {name: tip, point: [-0.1, 0.2, 0.0], '
                 'orientation: false}]', gravity=False, twist=f'{{angular: {spin}}}')
    names = [(imu.name, imu.frame) for imu in spec.bodies[0].imus]
    assert names == [('imu', 'imu'), ('tip', 'tip')]
    _, readings = read(spec, steps=37)
    np.testing.assert_allclose(readings.specific_force, -omega ** 2 * np.array(
        [[0.15, -0.05, 0.0], [-0.1, 0.2, 0.0]]), atol=1e-11)
    np.testing.assert_allclose(readings.orientation[0], (TILT * Rotation.from_rotvec(
        [0.0, 0.0, omega * 0.037])).as_quat(), atol=1e-9)
    np.testing.assert_array_equal(readings.orientation[1], 0.0)   # it publishes none
    twins = scene('[%s, %s]' % (NOISY % 4, (NOISY % 4)[:-1] + ', name: twin}'), gravity=False)
    world = build_world(twins, 'rk4')
    both = build_imus(twins.bodies, world.bodies, None).read(world, [0, 1]).angular_velocity
    alone = noisy_readings(4, 1, 0.01)[0][0]
    np.testing.assert_array_equal(both[0], alone)
    assert not np.array_equal(both[1], alone)


def test_imu_topic_over_ros(rigid_sim):
    """The ~/box/imu topic carries frame, stamps, covariances and readings as specified.

    Frame box/imu, stamps of simulated time, covariances from the noise model, and a body
    held up by m g reading +g along world up (every tick: no rate given).
    """
    text = f"""
effects: {{gravity: {{acceleration: {G.tolist()}}}}}
bodies:
  - name: box
    shape: {{type: box, size: {SIZE.tolist()}}}
    mass: {MASS}
    pose: {{orientation: {TILT.as_quat().tolist()}}}
    imu: {{point: {OFFSET.tolist()}, noise: {{gyro: {{stddev: 0.5}}}}}}
  - name: plain
    shape: {{type: sphere, radius: 0.1}}
    mass: 1.0
"""
    sim = rigid_sim(yaml=text, time_step=1 / 64, wrench_timeout=0.0)
    probe = sim.create_node('probe')
    readings = []
    probe.create_subscription(Imu, sim.topic('box/imu'), readings.append, 100)
    push = probe.create_publisher(WrenchStamped, sim.topic('box/wrench'), 10)
    sim.connect()
    assert sim.node.count_publishers(sim.topic('plain/imu')) == 0
    push.publish(ros_tools.wrench('world', -MASS * G))
    sim.step(3)
    assert [conversions.to_seconds(m.header.stamp) for m in readings] == [1 / 64, 2 / 64, 3 / 64]
    last = readings[-1]
    assert last.header.frame_id == 'box/imu'
    np.testing.assert_allclose(conversions.vector_array(last.linear_acceleration),
                               TILT.inv().apply([0.0, 0.0, 9.81]), atol=1e-12)
    np.testing.assert_array_equal(last.angular_velocity_covariance,
                                  np.diag([0.25] * 3).ravel())
    np.testing.assert_array_equal(last.linear_acceleration_covariance, 0.0)
    np.testing.assert_array_equal(last.orientation_covariance, 0.0)
    np.testing.assert_allclose([last.orientation.x, last.orientation.y, last.orientation.z,
                                last.orientation.w], TILT.as_quat(), atol=1e-15)


def test_several_imus_a_magnetometer_and_no_orientation_over_ros(rigid_sim):
    """Each IMU of a list publishes on ~/<body>/<name>, a magnetometer on ~/<body>/<name>/mag.

    The one without orientation sends a zero quaternion with orientation_covariance[0] = -1
    (REP-145); the magnetometer reads R^T B with its noise variance on the diagonal.
    """
    sigma = 1.0e-7
    text = f"""
{MAGNETIC}bodies:
  - name: box
    shape: {{type: box, size: {SIZE.tolist()}}}
    mass: {MASS}
    pose: {{orientation: {TILT.as_quat().tolist()}}}
    points: {{tip: [0.2, 0.0, 0.0]}}
    imu:
      - {{point: {OFFSET.tolist()}, magnetometer: true, noise: {{mag: {{stddev: {sigma}}}}}}}
      - {{name: blind, point: tip, orientation: false, rate: 32.0}}
"""
    sim = rigid_sim(yaml=text, time_step=1 / 64)
    probe = sim.create_node('probe')
    fields, blind = [], []
    probe.create_subscription(MagneticField, sim.topic('box/imu/mag'), fields.append, 100)
    probe.create_subscription(Imu, sim.topic('box/blind'), blind.append, 100)
    sim.step(4)
    # At 32 Hz: the first tick at or after t = 0, 1/32 and 2/32 s (the first tick ends at 1/64).
    assert [conversions.to_seconds(m.header.stamp) for m in blind] == [1 / 64, 1 / 32, 2 / 32]
    assert blind[-1].header.frame_id == 'box/tip'
    assert blind[-1].orientation_covariance[0] == -1.0
    orientation = blind[-1].orientation
    assert (orientation.x, orientation.y, orientation.z, orientation.w) == (0.0, 0.0, 0.0, 0.0)
    assert len(fields) == 4 and fields[-1].header.frame_id == 'box/imu'
    np.testing.assert_allclose(fields[-1].magnetic_field_covariance,
                               np.diag([sigma ** 2] * 3).ravel(), rtol=1e-15)
    error = conversions.vector_array(fields[-1].magnetic_field) - TILT.inv().apply(FIELD)
    assert 0.0 < np.abs(error).max() < 6 * sigma   # noisy, within six standard deviations
    reading = sim.imu('box')
    assert reading.magnetic_field.tolist() == conversions.vector_array(
        fields[-1].magnetic_field).tolist()
    assert sim.imu('box', 'blind').orientation is None


def test_packaged_imu_scene_reads_what_its_comment_and_the_readme_say():
    """The IMU of config/scenes/imu.yaml reads what its comment and the README say.

    Hanging still while spinning at 2 rad/s, the IMU 0.1 m out reads omega (0, 0, 2) and
    f = (-omega^2 r, 0, g) in body axes, at any time.
    """
    from pathlib import Path

    from rigid_sim.core.scene import load_scene
    path = Path(__file__).resolve().parents[1] / 'config' / 'scenes' / 'imu.yaml'
    spec = load_scene(path)
    world = build_world(spec, 'rk4')
    for _ in range(100):
        assert world.step(0.01)
    imus = build_imus(spec.bodies, world.bodies, spec.effects['gravity']['acceleration'])
    exact = imus.exact(world, [0])
    np.testing.assert_allclose(exact.angular_velocity[0], [0.0, 0.0, 2.0], atol=1e-9)
    np.testing.assert_allclose(exact.specific_force[0], [-0.4, 0.0, 9.81], atol=1e-4)


def test_the_readme_example_of_several_imus_publishes_what_its_comments_say(rigid_sim):
    """The README's drone: ~/drone/imu with ~/drone/imu/mag and no orientation, ~/drone/nose_imu.

    Level and at rest without gravity, the magnetometer reads the field itself.
    """
    from pathlib import Path
    readme = (Path(__file__).resolve().parents[1] / 'README.md').read_text()
    text, = [block for block in re.findall(r'```yaml\n(.*?)```', readme, re.S)
             if 'name: drone' in block]
    sim = rigid_sim(yaml=text)
    published = {p.topic_name: p.msg_type for p in sim.node.publishers}
    assert published['/rigid_sim/drone/imu'] is Imu
    assert published['/rigid_sim/drone/imu/mag'] is MagneticField
    assert published['/rigid_sim/drone/nose_imu'] is Imu
    sim.step(1)
    first, nose = sim.imu('drone'), sim.imu('drone', 'nose_imu')
    assert (first.frame_id, nose.frame_id) == ('drone/imu', 'drone/nose')
    assert first.orientation is None and nose.orientation.tolist() == [0.0, 0.0, 0.0, 1.0]
    field = yaml.safe_load(text)['magnetic_field']
    assert np.abs(first.magnetic_field - field).max() < 6 * 1.0e-7
