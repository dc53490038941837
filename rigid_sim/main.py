# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Entry point of the ``rigid_sim_node`` executable."""
import sys

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from rigid_sim.core.scene import SceneError
from rigid_sim.node import NODE_NAME, RigidSimNode
from rigid_sim.parameters import ParameterError


def main(args=None):
    """Run the node until SIGINT; return 0, or 1 when a parameter or the scene is refused."""
    rclpy.init(args=args)
    try:
        return _run()
    except (KeyboardInterrupt, ExternalShutdownException):
        # SIGINT may come at any moment, even while the node is built or destroyed.
        return 0
    finally:
        rclpy.try_shutdown()


def _run():
    try:
        node = RigidSimNode()
    except (ParameterError, SceneError, FileNotFoundError) as error:
        rclpy.logging.get_logger(NODE_NAME).error(f'refused to start: {error}')
        return 1
    try:
        # Not the EventsExecutor: its spin() hangs on these wheels (docs/ros_notes.md).
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
    finally:
        node.destroy_node()
    return 0


if __name__ == '__main__':
    sys.exit(main())
