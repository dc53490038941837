# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Messages of every body kept serialised: the bytes read back as the message itself.

The oracle is rclpy's own serialisation of the message object carrying the same poses and
stamp, both read back by rclpy and compared field by field, whatever the frames, the
shapes and the count. (Bytes are not compared: CDR's alignment padding is not zeroed, so
two serialisations of one message may differ there.)
"""
import numpy as np
import pytest
import yaml
from geometry_msgs.msg import Pose, PoseArray
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import MarkerArray

from rigid_sim import conversions
from rigid_sim.core.scene import parse_scene
from rigid_sim.serialized import MARK, SerializedPoses

SHAPES = """
bodies:
  - {name: box, shape: {type: box, size: [0.4, 0.2, 0.1]}, mass: 2.0}
  - {name: ball, shape: {type: sphere, radius: 0.1}, mass: 1.0}
  - {name: can, shape: {type: cylinder, radius: 0.05, length: 0.3}, mass: 1.0}
"""


class Publisher:
    """Keeps what it is given to publish."""

    def publish(self, data):
        self.data = data


def _random_frames(rng, count):
    quaternions = rng.normal(size=(count, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1)[:, None]
    origins = rng.normal(scale=1e3, size=(count, 3))
    return np.hstack([origins, quaternions, rng.normal(size=(count, 12))])


def _as_objects(frames, poses, stamp, seconds):
    for pose, row in zip(poses, frames.tolist()):
        conversions.fill_pose(pose, row[0:3], row[3:7])
    conversions.to_time(seconds, stamp)


def _read(data, message):
    """Deserialise ``data`` as ``message``'s type (float32 fields, colours, come back rounded)."""
    return deserialize_message(data, type(message))


def _sent(serialized):
    publisher = Publisher()
    serialized.publish(publisher)
    return publisher.data


@pytest.mark.parametrize('count', [0, 1, 7, 300])
def test_a_pose_array_written_in_place_reads_back_as_the_message(count):
    rng = np.random.default_rng(count)
    message = PoseArray(poses=[Pose() for _ in range(count)])
    message.header.frame_id = 'world'
    serialized = SerializedPoses(message, [(p.position, p.orientation) for p in message.poses],
                                 message.header.stamp, 1)
    for seconds in (0.0, 12.345678901, 1.5e6):
        frames = _random_frames(rng, count)
        _as_objects(frames, message.poses, message.header.stamp, seconds)
        serialized.write(frames, message.header.stamp)
        assert _read(_sent(serialized), message) == _read(serialize_message(message), message)


def test_markers_of_every_shape_written_in_place_read_back_as_the_message():
    scene = parse_scene(yaml.safe_load(SHAPES))
    messages = conversions.StateMessages(scene.bodies, 'map', 'robot1/')
    frames = _random_frames(np.random.default_rng(3), len(scene.bodies))
    _as_objects(frames, messages.pose_array.poses, messages.stamp, 7.25)
    for serialized, message in ((messages.serialized_markers, messages.markers),
                                (messages.serialized_poses, messages.pose_array)):
        serialized.write(frames, messages.stamp)
        assert _read(_sent(serialized), message) == _read(serialize_message(message), message)


def test_marking_the_fields_leaves_the_message_as_it_was():
    message = PoseArray(poses=[Pose() for _ in range(3)])
    message.poses[1].position.y, message.header.stamp.sec = -2.5, 41
    before = serialize_message(message)
    SerializedPoses(message, [(p.position, p.orientation) for p in message.poses],
                    message.header.stamp, 1)
    assert message == deserialize_message(before, PoseArray)


def test_a_field_holding_a_frame_of_marks_is_refused_not_guessed():
    message = PoseArray(poses=[Pose() for _ in range(2)])
    conversions.fill_pose(message.poses[1], [MARK, MARK + 1, MARK + 2],
                          [MARK + 3, MARK + 4, MARK + 5, MARK + 6])   # frame 0's marks
    with pytest.raises(RuntimeError, match='runs of marked pose values found'):
        SerializedPoses(message, [(message.poses[0].position, message.poses[0].orientation)],
                        message.header.stamp, 1)
    with pytest.raises(RuntimeError, match='marked stamps found'):
        SerializedPoses(MarkerArray(), [], message.header.stamp, 1)
