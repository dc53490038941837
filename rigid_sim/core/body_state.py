# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Setting one body's pose or twist between steps, as a new packed state.

A body's pose and twist are given as the node publishes them: the body frame's origin and
orientation in the world, the velocity of that origin and the angular velocity, world axes.
The packed Baraff state holds the centre of mass ``x`` and the momenta ``P``, ``L``, so the
change goes through the centre-of-mass offset ``c`` (body frame) and the inertia:

    x = o + R c,   P = M (v_o + omega x R c),   L = R I_body R^T omega.

Setting the pose keeps the body's twist (origin velocity and angular velocity), setting the
twist keeps its pose. Every other row of the state, and time, stay exactly as they were:
the functions return a new array and never write into the one they are given.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core.input_values import checked
from rigid_sim.core.state import frame_rows, packed_rows

# |q.q - 1| above this is a quaternion nobody meant as a rotation (tf2 refuses the same);
# within it, q is normalised, as a float32-rounded or hand-typed unit quaternion needs.
UNIT_QUATERNION_TOLERANCE = 1.0e-2


def unit_quaternion(q):
    """``q`` (x, y, z, w) normalised; ValueError if refused as an input or far from unit length."""
    q = checked('orientation', q, 'xyzw')
    squared = float(q @ q)
    if abs(squared - 1.0) > UNIT_QUATERNION_TOLERANCE:
        raise ValueError(f'orientation {q.tolist()} is not a unit quaternion: |q|^2 = '
                         f'{squared:.6g}, more than {UNIT_QUATERNION_TOLERANCE:g} from 1')
    return q / np.sqrt(squared)


def body_frame_state(bodies, y, index):
    """Pose and twist of body ``index``'s frame in packed state ``y``.

    Returns
    -------
    origin : (3,) m, world;  orientation : (4,) (x, y, z, w), body to world;
    velocity : (3,) m/s of the origin, world;  angular_velocity : (3,) rad/s, world
    """
    row = frame_rows(bodies, y, slice(index, index + 1))[0]
    return row[0:3], row[3:7], row[7:10], row[10:13]


def _with_row(bodies, y, index, origin, orientation, velocity, angular_velocity):
    """``y`` copied, with row ``index`` packed from the body frame's pose and twist."""
    new = np.array(y, dtype=float, copy=True)
    new[index] = packed_rows(bodies, slice(index, index + 1), origin[None], orientation[None],
                             velocity[None], angular_velocity[None])[0]
    return new


def with_pose(bodies, y, index, origin, orientation):
    """Return a new state with body ``index``'s frame at ``origin`` and ``orientation``.

    ``origin`` is (3,), m, world frame; ``orientation`` is (4,), (x, y, z, w), body to world.

    The body keeps its twist (velocity of its frame origin and angular velocity, world
    axes). ValueError, nothing changed, for a value the input checks refuse
    (:func:`rigid_sim.core.input_values.checked`) or a quaternion further than
    ``UNIT_QUATERNION_TOLERANCE`` from unit length (within it, it is normalised).
    """
    origin = checked('position', origin)
    orientation = unit_quaternion(orientation)
    _, _, velocity, angular_velocity = body_frame_state(bodies, y, index)
    return _with_row(bodies, y, index, origin, orientation, velocity, angular_velocity)


def with_twist(bodies, y, index, velocity, angular_velocity):
    """Return a new state with body ``index``'s twist set and its pose kept.

    The frame origin moves at ``velocity`` (3,), m/s, and the body turns at
    ``angular_velocity`` (3,), rad/s, both in world axes. ValueError, nothing changed, for a
    value the input checks refuse (:func:`rigid_sim.core.input_values.checked`): within
    the scene's number bound the momenta stay finite, as those of a loaded scene do.
    """
    velocity = checked('linear', velocity)
    angular_velocity = checked('angular', angular_velocity)
    origin, orientation, _, _ = body_frame_state(bodies, y, index)
    return _with_row(bodies, y, index, origin, orientation, velocity, angular_velocity)


def seen_in_world(frame, relative):
    """Return a body frame's pose and twist given relative to another moving frame, in world.

    Parameters
    ----------
    frame : tuple
        (origin (3,) m, orientation (4,) (x, y, z, w), velocity (3,) m/s of the origin,
        angular velocity (3,) rad/s), world, as :func:`body_frame_state` gives them: the
        frame the pose and twist are given in.
    relative : tuple
        The same four of the body frame, in ``frame``'s axes and relative to it.

    Returns
    -------
    tuple
        The same four in world: ``p_f + R p``, ``q_f q``, ``v_f + w_f x R p + R v``,
        ``w_f + R w``.
    """
    turn = Rotation.from_quat(frame[1])
    offset = turn.apply(relative[0])
    return (frame[0] + offset, (turn * Rotation.from_quat(relative[1])).as_quat(),
            frame[2] + np.cross(frame[3], offset) + turn.apply(relative[2]),
            frame[3] + turn.apply(relative[3]))
