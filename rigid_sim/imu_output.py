# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's IMU outputs: ``~/<body>/<name>`` for every IMU a scene declares.

An IMU's name is ``imu`` unless its scene entry gives one, so a body's single IMU publishes
``~/<body>/imu``; an IMU with a magnetometer also publishes ``~/<body>/<name>/mag``. A
scene without an IMU gets no publisher and costs one attribute test per tick. The readings
are taken whenever an IMU is due, listened to or not, so that the noise an IMU draws does
not depend on who subscribes: a seeded run reads the same whoever watches.
"""
from sensor_msgs.msg import Imu, MagneticField

from rigid_sim import conversions
from rigid_sim.core.imu import scene_imus
from rigid_sim.qos_overrides import QUEUE_DEPTH


class ImuOutputs:
    """The IMUs of one scene and their publishers.

    Parameters
    ----------
    node : rigid_sim.node.RigidSimNode
        Its ``qos_overrides`` make the IMU publishers, which it destroys when the scene goes.
    scene : rigid_sim.core.scene.Scene
        The scene whose bodies may carry IMUs.
    world : rigid_sim.core.world.World
        The world of that scene, whose state the IMUs read.
    frame_prefix : str
        Prefixed to the IMU frames.
    """

    def __init__(self, node, scene, world, frame_prefix):
        self._node = node
        self.imus = None          # rigid_sim.core.imu.Imus, None when the scene has none
        self._publishers = []     # per IMU: the Imu publisher, the MagneticField one or None
        self._names = []          # per IMU, the name of its body
        self._messages = []       # per IMU, as the publishers: refilled at each reading
        self.wire(scene, world, frame_prefix)

    def wire(self, scene, world, frame_prefix):
        """Replace the IMUs and publishers by those of ``scene``."""
        for publisher in (p for pair in self._publishers for p in pair if p is not None):
            self._node.destroy_publisher(publisher)
        self.imus = scene_imus(scene, world)
        if self.imus is None:
            self._publishers, self._messages = [], []
            return
        self._names = [scene.bodies[index].name for index in self.imus.bodies]
        create = self._node.qos_overrides.create_publisher
        self._publishers = [
            (create(Imu, f'~/{body}/{spec.name}', QUEUE_DEPTH),
             create(MagneticField, f'~/{body}/{spec.name}/mag', QUEUE_DEPTH)
             if spec.magnetometer else None)
            for body, spec in zip(self._names, self.imus.specs)]
        self.set_frame_prefix(frame_prefix)

    def set_frame_prefix(self, frame_prefix):
        """Rebuild the reused messages with IMU frames ``<prefix><body>/<frame>``."""
        if self.imus is not None:
            frames = [f'{frame_prefix}{name}/{spec.frame}'
                      for name, spec in zip(self._names, self.imus.specs)]
            self._messages = [
                (conversions.imu_message(frame, spec),
                 conversions.magnetic_field_message(frame, spec) if spec.magnetometer else None)
                for frame, spec in zip(frames, self.imus.specs)]

    def restart(self):
        """Every IMU due again and its noise drawn anew from its seed (time went back to 0)."""
        if self.imus is not None:
            self.imus.restart()

    def publish(self, world):
        """Read and publish every IMU that is due at the world's time."""
        if self.imus is None:
            return
        which = self.imus.due(world.time)
        if not which:
            return
        readings = self.imus.read(world, which)
        for row, k in enumerate(which):
            (imu, magnetometer), (message, field) = self._publishers[k], self._messages[k]
            conversions.fill_imu(message, readings, row)
            imu.publish(message)
            if magnetometer is not None:
                conversions.fill_magnetic_field(field, readings, row)
                magnetometer.publish(field)
