# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""A body's ``imu`` scene entry: one IMU (a mapping) or several (a list of mappings).

Each IMU has a name, distinct on its body, which names its topic ``~/<body>/<name>``
(``imu`` by default, so a single IMU keeps ``~/<body>/imu``); its frame is the named point
it sits at, or ``<body>/<name>`` when placed by coordinates. It may leave out the
orientation (REP-145: an IMU without an orientation estimate says so) and may carry a
magnetometer, which reads the scene's ``magnetic_field`` in the body's axes.
"""
from dataclasses import dataclass

import numpy as np

from rigid_sim.core.imu_noise import SensorNoise
from rigid_sim.core.scene_fields import (
    ABSENT, MAX_MAGNITUDE, Mistake, non_negative, number, of_type, positive, raw, table, token,
    vector, fields)

DEFAULT_NAME = 'imu'   # the name, and so the topic, of an IMU that gives none
# The body's other topics ~/<body>/<topic>: an IMU named like one would share its topic.
OTHER_BODY_TOPICS = ('pose', 'twist', 'odom', 'wrench', 'set_pose', 'set_twist')
SENSORS = ('gyro', 'accel', 'mag')   # rad/s, m/s^2, T
NOISE = {'stddev': (non_negative, 0.0), 'bias_mean': (number, 0.0),
         'bias_stddev': (non_negative, 0.0), 'dynamic_bias_stddev': (non_negative, 0.0),
         'dynamic_bias_correlation_time': (positive, ABSENT)}
FLAG = of_type(bool, 'true or false')
IMU = {'name': (token, DEFAULT_NAME), 'point': (raw, [0.0, 0.0, 0.0]),
       'rate': (positive, ABSENT), 'orientation': (FLAG, True), 'magnetometer': (FLAG, False),
       'noise': (table({sensor: (table(NOISE), ABSENT) for sensor in SENSORS}), ABSENT),
       'seed': (of_type(int, 'a whole number'), 0)}


@dataclass(frozen=True)
class ImuSpec:
    """One IMU as the scene declares it."""

    point: np.ndarray   # (3,) m, body-frame coordinates of the mount point
    frame: str          # child frame name: <body>/<frame> (a named point, or the name)
    rate: float         # Hz of simulated time; None: every tick
    gyro: SensorNoise   # None: exact angular velocity
    accel: SensorNoise  # None: exact specific force
    seed: int           # of this IMU's noise stream
    name: str = DEFAULT_NAME   # distinct on its body: the topic ~/<body>/<name>
    orientation: bool = True   # False: publishes no orientation (REP-145)
    magnetometer: bool = False  # True: also reads the scene's magnetic field
    mag: SensorNoise = None     # None: exact magnetic field


def parse_imus(value, key, points, has_field):
    """Parse a body's ``imu`` entry, a mapping or a list of them, into ImuSpecs.

    Parameters
    ----------
    value : dict or list
        The entry as YAML gave it.
    key : str
        Its key path, for messages (``bodies[0].imu``).
    points : dict
        The body's named points.
    has_field : bool
        Whether the scene gives a ``magnetic_field`` (a magnetometer needs one).

    Returns
    -------
    tuple of ImuSpec
        In the order given.

    Raises
    ------
    rigid_sim.core.scene_fields.Mistake
        Naming the key and the reason.
    """
    if not isinstance(value, list):
        return (parse_imu(value, key, points, has_field),)
    if not value:
        raise Mistake(key, 'expected an IMU (a mapping) or a non-empty list of them')
    specs, first = [], {}
    for i, entry in enumerate(value):
        spec = parse_imu(entry, f'{key}[{i}]', points, has_field)
        if spec.name in first:
            raise Mistake(f'{key}[{i}].name', f'duplicate IMU name {spec.name!r} (also '
                                              f'{key}[{first[spec.name]}]): each IMU of a '
                                              'body needs its own name, its topic')
        first[spec.name] = i
        specs.append(spec)
    return tuple(specs)


def parse_imu(value, key, points, has_field):
    """Parse one IMU mapping into an :class:`ImuSpec`; see :func:`parse_imus`."""
    imu = fields(value, key, IMU)
    name = imu['name']
    if name in OTHER_BODY_TOPICS:
        raise Mistake(f'{key}.name', f'{name!r} is the topic ~/<body>/{name}; name the IMU '
                                     'otherwise')
    point = imu['point']
    if isinstance(point, str):
        if point not in points:
            raise Mistake(f'{key}.point', f'no point named {point!r}; the body has '
                                          f'{sorted(points)} (or give [x, y, z])')
        where, frame = points[point], point
    else:
        if name in points:
            raise Mistake(f'{key}.point', f'the body has a point named {name!r}, the frame '
                                          'of an IMU of that name given by coordinates: '
                                          'place it at that point or name it otherwise')
        where, frame = vector(point, f'{key}.point'), name
    # Bounded as every number of a scene is, though numpy would take any size of seed.
    if not 0 <= imu['seed'] <= MAX_MAGNITUDE:
        raise Mistake(f'{key}.seed', f'must be a whole number >= 0 and at most '
                                     f'{MAX_MAGNITUDE:g}')
    noise = imu.get('noise', {})
    if imu['magnetometer'] and not has_field:
        raise Mistake(f'{key}.magnetometer', 'the scene gives no magnetic_field (tesla, world '
                                             'axes) for a magnetometer to read')
    if 'mag' in noise and not imu['magnetometer']:
        raise Mistake(f'{key}.noise.mag', 'noise of a magnetometer the IMU does not have '
                                          '(set magnetometer: true)')
    sensors = {sensor: SensorNoise(**noise[sensor]) if sensor in noise else None
               for sensor in SENSORS}
    return ImuSpec(point=np.array(where, dtype=float), frame=frame, rate=imu.get('rate'),
                   seed=imu['seed'], name=name, orientation=imu['orientation'],
                   magnetometer=imu['magnetometer'], **sensors)
