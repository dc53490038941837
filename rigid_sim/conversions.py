# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Messages <-> arrays: the only place ROS messages meet the core's numpy arrays.

Output messages are built once per scene and refilled on every publication: the pose of a
body is one ``Pose`` object shared by its PoseStamped and its Odometry, and one ``Time``
object is the stamp of them all. rclpy serialises a message when it is published, so reusing
the objects is safe and saves building ~10 messages per body per tick. The messages of every
body (the PoseArray, the markers, /tf) are kept serialised instead
(:mod:`rigid_sim.serialized`), their poses written into the bytes.
Quaternions are (x, y, z, w) in ROS messages and in the core alike.
"""
import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import (
    Point, Pose, PoseArray, PoseStamped, TransformStamped, TwistStamped)
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import Imu, MagneticField
from visualization_msgs.msg import Marker, MarkerArray

from rigid_sim.serialized import SerializedPoses

NANOSECONDS = 1_000_000_000
# One colour per body, cycled: distinguishable shapes in RViz (RGBA, 0..1).
PALETTE = ((0.90, 0.35, 0.20), (0.20, 0.55, 0.90), (0.30, 0.75, 0.35), (0.85, 0.75, 0.20),
           (0.60, 0.40, 0.80), (0.40, 0.80, 0.80))


def to_time(seconds, stamp=None):
    """Return simulated ``seconds`` as a builtin_interfaces/Time (filled into ``stamp``)."""
    stamp = Time() if stamp is None else stamp
    stamp.sec, stamp.nanosec = divmod(int(round(seconds * NANOSECONDS)), NANOSECONDS)
    return stamp


def to_seconds(stamp):
    """Return a builtin_interfaces/Time as float seconds."""
    return stamp.sec + stamp.nanosec / NANOSECONDS


def wrench_arrays(message):
    """Force (3,) N and torque (3,) N m of a geometry_msgs/WrenchStamped (checked in the core)."""
    force, torque = message.wrench.force, message.wrench.torque
    return np.array((force.x, force.y, force.z)), np.array((torque.x, torque.y, torque.z))


def pose_arrays(pose):
    """Position (3,) m and orientation (4,) (x, y, z, w) of a geometry_msgs/Pose."""
    p, q = pose.position, pose.orientation
    return np.array((p.x, p.y, p.z)), np.array((q.x, q.y, q.z, q.w))


def vector_array(vector):
    """Return a geometry_msgs/Vector3 as a (3,) array."""
    return np.array((vector.x, vector.y, vector.z))


class StateMessages:
    """The per-tick outputs of N bodies, refilled in place from a Snapshot.

    Parameters
    ----------
    bodies : sequence of BodySpec
        The scene's N bodies, in scene order.
    world_frame : str
        The frame_id of every pose and world-axes twist.
    frame_prefix : str
        Prefixed to the body frames (odometry child, transforms).

    Attributes
    ----------
    poses, twists, odometry : list of N PoseStamped, TwistStamped, Odometry
        One per body, in scene order.
    pose_array : PoseArray
        The same N Pose objects, as built (the poses go out by ``serialized_poses``).
    markers : MarkerArray
        One marker per body, sharing the same Pose objects, as built (``serialized_markers``).
    serialized_poses, serialized_markers : rigid_sim.serialized.SerializedPoses
        The PoseArray and the markers, serialised: each publication writes every pose.
    transforms : list of N TransformStamped
        World_frame -> body frame, as built: /tf goes out serialised (StateOutputs).
    """

    def __init__(self, bodies, world_frame, frame_prefix=''):
        self.stamp = Time()
        shared_poses = [Pose() for _ in bodies]
        self.poses = [PoseStamped(pose=pose) for pose in shared_poses]
        self.twists = [TwistStamped() for _ in bodies]
        self.odometry = [Odometry(child_frame_id=frame_prefix + body.name) for body in bodies]
        self.pose_array = PoseArray(poses=shared_poses)
        self.markers = MarkerArray(markers=[marker(i, body, pose)
                                            for i, (body, pose) in enumerate(zip(bodies,
                                                                                 shared_poses))])
        self.transforms = [TransformStamped(child_frame_id=frame_prefix + body.name)
                           for body in bodies]
        headers = ([m.header for m in self.poses + self.twists + self.odometry]
                   + [self.pose_array.header] + [m.header for m in self.markers.markers]
                   + [t.header for t in self.transforms])
        for header in headers:
            header.frame_id = world_frame
            header.stamp = self.stamp
        for odometry, pose in zip(self.odometry, shared_poses):
            odometry.pose.pose = pose
        frames = [(pose.position, pose.orientation) for pose in shared_poses]
        self.serialized_poses = SerializedPoses(self.pose_array, frames, self.stamp, 1)
        self.serialized_markers = SerializedPoses(self.markers, frames, self.stamp, len(frames))

    def fill(self, snapshot, posed, moving):
        """Write the poses of ``posed`` and the twists of ``moving`` at ``snapshot``.

        ``posed`` and ``moving`` are iterables of body indices; each message costs Python time. The
        world and body twists are written. Every message's stamp is the snapshot's time; the others
        keep their last values.
        """
        to_time(snapshot.time, self.stamp)
        # [origin, orientation, world twist, body-axes twist (REP-105: odometry's)] per body,
        # as Python rows only for the bodies posed: 10 000 rows at every publication were a
        # quarter of the node's time with 5000 of its bodies heard.
        frames = snapshot.frames
        if len(posed) < len(frames):
            rows = dict(zip(posed, frames[list(posed)].tolist()))
        else:
            rows = frames.tolist()
        for index in posed:
            _set_pose(self.poses[index].pose, rows[index][0:7])
        for index in moving:
            row = rows[index]
            _set_twist(self.twists[index].twist, row[7:13])
            _set_twist(self.odometry[index].twist.twist, row[13:19])


def static_transforms(bodies, frame_prefix, seconds):
    """Build the static transforms from each body frame to its named points and IMU frame.

    Parameters
    ----------
    bodies : sequence of BodySpec
        The scene's bodies; ``points`` maps a name to its (3,) position, m, body frame,
        and ``imus`` its ImuSpecs.
    frame_prefix : str
        Prefixed to every frame name.
    seconds : float
        Simulated time of the stamp, s.

    Returns
    -------
    list of TransformStamped
        Parent ``<prefix><body>``, child ``<prefix><body>/<point>`` (``<prefix><body>/<name>``
        for an IMU placed by coordinates), identity rotation.
    """
    transforms = []
    for body in bodies:
        points = dict(body.points)
        for imu in body.imus:
            points.setdefault(imu.frame, imu.point)
        for name, point in points.items():
            transform = TransformStamped(child_frame_id=f'{frame_prefix}{body.name}/{name}')
            transform.header.frame_id = frame_prefix + body.name
            to_time(seconds, transform.header.stamp)
            t = transform.transform.translation
            t.x, t.y, t.z = (float(v) for v in point)
            transforms.append(transform)
    return transforms


def delete_all_markers():
    """Build a MarkerArray that clears every marker of this publisher in RViz."""
    return MarkerArray(markers=[Marker(action=Marker.DELETEALL)])


def fill_pose(pose, origin, orientation):
    """Set a geometry_msgs/Pose from (3,) ``origin`` and (4,) (x, y, z, w) ``orientation``."""
    _set_pose(pose, [float(v) for v in (*origin, *orientation)])


def fill_twist(twist, linear, angular):
    """Set a geometry_msgs/Twist from (3,) ``linear`` and (3,) ``angular`` velocities."""
    _set_twist(twist, [float(v) for v in (*linear, *angular)])


def path_message(frame_id, times, origins, orientations):
    """Return a nav_msgs/Path of poses at ``times`` (M,) s in ``frame_id``.

    ``origins`` (M, 3) m and ``orientations`` (M, 4) (x, y, z, w); stamped with the first
    time.
    """
    path = Path()
    path.header.frame_id = frame_id
    to_time(float(times[0]), path.header.stamp)
    for time, pose in zip(times, np.hstack((origins, orientations)).tolist()):
        stamped = PoseStamped()
        stamped.header.frame_id = frame_id
        to_time(float(time), stamped.header.stamp)
        _set_pose(stamped.pose, pose)
        path.poses.append(stamped)
    return path


def _set_pose(pose, values):
    position, q = pose.position, pose.orientation
    position.x, position.y, position.z = values[0:3]
    q.x, q.y, q.z, q.w = values[3:7]


def _set_twist(twist, values):
    linear, angular = twist.linear, twist.angular
    linear.x, linear.y, linear.z = values[0:3]
    angular.x, angular.y, angular.z = values[3:6]


def marker(index, body, pose):
    """Return the RViz marker of one body's shape, drawn at ``pose`` (its body frame).

    ``body`` is a scene BodySpec; cylinders are along the body z axis, as RViz draws them.
    """
    shape = body.shape
    result = Marker(ns=body.name, id=index, action=Marker.ADD, pose=pose, frame_locked=False)
    red, green, blue = PALETTE[index % len(PALETTE)]
    result.color.r, result.color.g, result.color.b, result.color.a = red, green, blue, 1.0
    if shape['type'] == 'box':
        result.type = Marker.CUBE
        scale = shape['size']
    elif shape['type'] == 'sphere':
        result.type = Marker.SPHERE
        scale = np.full(3, 2.0 * shape['radius'])
    elif shape['type'] == 'cylinder':
        result.type = Marker.CYLINDER
        diameter = 2.0 * shape['radius']
        scale = (diameter, diameter, shape['length'])
    else:
        result.type = Marker.MESH_RESOURCE
        result.mesh_resource = 'file://' + shape['file']
        scale = np.broadcast_to(shape['scale'], 3)
    result.scale.x, result.scale.y, result.scale.z = (float(s) for s in scale)
    return result


# Drawn size of the contact markers: a ground plane's square side and thickness, the
# length of a contact's normal arrow and its shaft's width, m.
GROUND_SIDE, GROUND_THICKNESS, ARROW_LENGTH, ARROW_WIDTH = 10.0, 0.002, 0.1, 0.01


def contact_markers(frame_id, seconds, planes, points, normals):
    """Return the MarkerArray of ~/contacts: the ground planes, then a contact arrow each.

    A DELETEALL first, so contacts gone since the last message disappear. ``planes`` (P, 4)
    unit normal and offset; ``points`` and ``normals`` (C, 3), world, m: each arrow starts
    at its contact point and points along the normal (the push on the first body).
    """
    markers = [Marker(action=Marker.DELETEALL)]
    for k, plane in enumerate(np.asarray(planes, dtype=float).tolist()):
        ground = Marker(ns='ground', id=k, type=Marker.CUBE, action=Marker.ADD)
        normal = np.array(plane[:3])
        # The rotation taking z to the normal: half-way quaternion (z + n), or a half
        # turn about x when the normal points down.
        half = np.array([0.0, 0.0, 1.0]) + normal
        if np.linalg.norm(half) < 1e-9:
            turn = [1.0, 0.0, 0.0, 0.0]
        else:
            half /= np.linalg.norm(half)
            turn = [*np.cross([0.0, 0.0, 1.0], half), float(half[2])]
        _set_pose(ground.pose, [*(plane[3] * normal).tolist(), *turn])
        ground.scale.x = ground.scale.y = GROUND_SIDE
        ground.scale.z = GROUND_THICKNESS
        ground.color.r = ground.color.g = ground.color.b = 0.6
        ground.color.a = 0.5
        markers.append(ground)
    arrows = zip(np.asarray(points).tolist(), np.asarray(normals).tolist())
    for k, (point, normal) in enumerate(arrows):
        arrow = Marker(ns='contacts', id=k, type=Marker.ARROW, action=Marker.ADD)
        arrow.pose.orientation.w = 1.0
        tip = [p + ARROW_LENGTH * n for p, n in zip(point, normal)]
        arrow.points = [Point(x=point[0], y=point[1], z=point[2]),
                        Point(x=tip[0], y=tip[1], z=tip[2])]
        arrow.scale.x, arrow.scale.y, arrow.scale.z = ARROW_WIDTH, 2 * ARROW_WIDTH, 0.0
        arrow.color.r, arrow.color.a = 1.0, 1.0
        markers.append(arrow)
    for marker_ in markers:
        marker_.header.frame_id = frame_id
        to_time(seconds, marker_.header.stamp)
    return MarkerArray(markers=markers)


def imu_message(frame_id, spec):
    """Build a sensor_msgs/Imu in ``frame_id`` with the covariances of ``spec`` (an ImuSpec).

    The angular velocity and linear acceleration covariances are diagonal: the variance of
    one reading's white noise (the bias is not white; it is what an estimator tracks). The
    orientation is exact: its covariance is zero, as for noise-free readings; sensor_msgs
    reads an all-zero covariance as "unknown". An IMU that publishes no orientation says so
    as REP-145 asks: ``orientation_covariance[0] = -1`` (and the orientation stays zero).
    """
    message = Imu()
    message.header.frame_id = frame_id
    for covariance, noise in ((message.angular_velocity_covariance, spec.gyro),
                              (message.linear_acceleration_covariance, spec.accel)):
        _set_variance(covariance, noise)
    if not spec.orientation:
        message.orientation_covariance[0] = -1.0
    return message


def magnetic_field_message(frame_id, spec):
    """Build a sensor_msgs/MagneticField in ``frame_id``, covariance from ``spec.mag``."""
    message = MagneticField()
    message.header.frame_id = frame_id
    _set_variance(message.magnetic_field_covariance, spec.mag)
    return message


def _set_variance(covariance, noise):
    """Diagonal of a 3x3 covariance: the white-noise variance (0: exact, or unknown)."""
    covariance[[0, 4, 8]] = 0.0 if noise is None else noise.variance


def fill_imu(message, readings, row):
    """Write row ``row`` of ``readings`` (rigid_sim.core.imu.Readings) into ``message``."""
    to_time(readings.time, message.header.stamp)
    q = message.orientation
    q.x, q.y, q.z, q.w = readings.orientation[row].tolist()
    _set_vector(message.angular_velocity, readings.angular_velocity[row])
    _set_vector(message.linear_acceleration, readings.specific_force[row])


def fill_magnetic_field(message, readings, row):
    """Write row ``row`` of ``readings``' magnetic field into a MagneticField ``message``."""
    to_time(readings.time, message.header.stamp)
    _set_vector(message.magnetic_field, readings.magnetic_field[row])


def _set_vector(vector, values):
    vector.x, vector.y, vector.z = values.tolist()


def diagnostics(name, stamp_seconds, level, summary, values):
    """Return a DiagnosticArray of one status; ``values`` maps key -> value (shown as text)."""
    status = DiagnosticStatus(level=level, name=name, message=summary, hardware_id='rigid_sim')
    status.values = [KeyValue(key=key, value=_text(value)) for key, value in values.items()]
    array = DiagnosticArray(status=[status])
    to_time(stamp_seconds, array.header.stamp)
    return array


def _text(value):
    if isinstance(value, np.ndarray):
        return ' '.join(f'{v:.9g}' for v in value)
    if isinstance(value, float):
        return f'{value:.9g}'
    return str(value)


def diagnostic_values(message):
    """Return the key -> text values of the first status of a DiagnosticArray."""
    return {item.key: item.value for item in message.status[0].values}
