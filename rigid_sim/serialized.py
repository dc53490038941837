# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Messages of every body kept serialised: a publication writes its poses into the bytes.

rclpy converts a message object field by field when it publishes it, and holds the
interpreter while it does: for 10 000 boxes one MarkerArray took 173 ms, one /tf message
68 ms and one PoseArray 20 ms (docs/performance.md), each one call that no executor can
interrupt, so control waited for them. ``Publisher.publish`` also takes the serialised
bytes. The bytes are rmw's own: the message is serialised once by
``rclpy.serialization`` with marked values in the fields a publication changes, the marks
found in the bytes give those fields' offsets, and each publication writes the poses and
the stamp there with numpy and publishes a copy of the bytes.
"""
import numpy as np
from rclpy.serialization import serialize_message

# The marks: the pose values k = 0..6 of frame i are MARK + 7 i + k, integers above 2^52
# (exact doubles, beyond the 1e15 a scene's every number is held to, so no size, scale or
# colour can look like one); every header's stamp is (MARK_SEC, MARK_NANOSEC). A mark
# found other than once is an error, never a guess.
MARK = 2.0 ** 52
MARK_SEC, MARK_NANOSEC = 2_000_000_011, 999_999_937
# The serialised payload follows a 4-byte encapsulation header, and CDR aligns doubles to
# 8 bytes from the payload's start.
PAYLOAD_START = 4
VALUES = 7   # origin (x, y, z) and orientation (x, y, z, w) of a frame


class SerializedPoses:
    """A message carrying N frames and a stamp, serialised once, rewritten in place.

    Parameters
    ----------
    message
        The message object (PoseArray, MarkerArray, TFMessage); only its frames and stamps
        change from one publication to the next.
    frames : sequence of (translation, rotation) pairs
        The N frames' objects in the message: a Point or Vector3, and a Quaternion.
    stamp : builtin_interfaces/Time
        The object every header of ``message`` shares as its stamp.
    headers : int
        How many headers share it.
    """

    def __init__(self, message, frames, stamp, headers):
        kept = [_values(frame) for frame in frames], (stamp.sec, stamp.nanosec)
        for index, frame in enumerate(frames):
            _set(frame, MARK + VALUES * index + np.arange(VALUES))
        stamp.sec, stamp.nanosec = MARK_SEC, MARK_NANOSEC
        try:
            self._buffer = bytearray(serialize_message(message))
        finally:
            for frame, values in zip(frames, kept[0]):
                _set(frame, values)
            stamp.sec, stamp.nanosec = kept[1]
        doubles = (len(self._buffer) - PAYLOAD_START) // 8
        self._doubles = np.frombuffer(self._buffer, np.float64, doubles, PAYLOAD_START)
        self._words = np.frombuffer(self._buffer, np.int32, len(self._buffer) // 4)
        self._frames = _marked_frames(self._doubles, len(frames))
        self._stamps = _marked_stamps(self._words, headers)
        self._doubles[self._frames] = np.reshape(kept[0], (-1, VALUES))
        self._words[self._stamps], self._words[self._stamps + 1] = kept[1]

    def write(self, frames, stamp):
        """Write ``frames`` ((N, >= 7): origin and (x, y, z, w)) and ``stamp`` (a Time)."""
        self._doubles[self._frames] = frames[:, :VALUES]
        self._words[self._stamps], self._words[self._stamps + 1] = stamp.sec, stamp.nanosec

    def publish(self, publisher):
        """Publish the message as last written (a copy of its bytes)."""
        publisher.publish(bytes(self._buffer))


def _values(frame):
    translation, rotation = frame
    return (translation.x, translation.y, translation.z,
            rotation.x, rotation.y, rotation.z, rotation.w)


def _set(frame, values):
    translation, rotation = frame
    translation.x, translation.y, translation.z = (float(v) for v in values[:3])
    rotation.x, rotation.y, rotation.z, rotation.w = (float(v) for v in values[3:])


def _marked_frames(doubles, count):
    """Return the (count, 7) indices of the marked frame values in ``doubles``.

    A frame's values are found as a run of its seven marks, never one by one: CDR's padding
    is not zeroed, so a double that spans padding may hold a mark's bytes left by an earlier
    serialisation (seen: MARK itself just before a marker's pose, its high word stale).
    """
    with np.errstate(invalid='ignore'):   # bytes read as doubles: signalling NaNs among them
        labels = doubles - MARK
        starts = np.flatnonzero((labels >= 0) & (labels < VALUES * count)
                                & (labels % VALUES == 0))
    starts = starts[starts + VALUES <= len(doubles)]
    run = starts[:, None] + np.arange(VALUES)
    starts = starts[np.all(labels[run] == labels[starts][:, None] + np.arange(VALUES), axis=1)]
    frames = (labels[starts] // VALUES).astype(np.int64)
    if len(starts) != count or np.any(np.bincount(frames, minlength=count) != 1):
        raise RuntimeError(f'{len(starts)} runs of marked pose values found in the '
                           f'serialised message, {count} expected once each')
    index = np.empty(count, np.int64)
    index[frames] = starts
    return index[:, None] + np.arange(VALUES)


def _marked_stamps(words, headers):
    """Return the indices of the marked stamps' seconds in ``words`` (nanoseconds follow)."""
    found = np.flatnonzero((words[:-1] == MARK_SEC) & (words[1:] == MARK_NANOSEC))
    if len(found) != headers:
        raise RuntimeError(f'{len(found)} marked stamps found in the serialised message, '
                           f'{headers} expected')
    return found
