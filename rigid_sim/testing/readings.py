# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""What the test kit reads back: a body's state and properties, an IMU's latest reading."""
from dataclasses import dataclass

import numpy as np

from rigid_sim import conversions

__all__ = ['BodyProperties', 'BodyState', 'ErrorEstimate', 'ImuReading']


@dataclass(frozen=True)
class BodyState:
    """One body's frame as the simulator publishes it: world axes, SI units."""

    position: np.ndarray          # (3,) m, body-frame origin
    orientation: np.ndarray       # (4,) (x, y, z, w), body to world
    velocity: np.ndarray          # (3,) m/s of the body-frame origin
    angular_velocity: np.ndarray  # (3,) rad/s
    time: float                   # s of simulated time


@dataclass(frozen=True)
class BodyProperties:
    """One body's mass properties, as the simulator uses them."""

    mass: float                   # kg
    inertia: np.ndarray           # (3, 3) kg m^2, about the centre of mass, body axes
    center_of_mass: np.ndarray    # (3,) m, centre of mass in body-frame coordinates


@dataclass(frozen=True)
class ErrorEstimate:
    """How wrong the integration is, as /diagnostics reports it (README: error estimates).

    Errors are relative, of each body's scaled state: 1e-6 is a millionth of the body's
    size, of a radian, or of its momentum.
    """

    last_step: float        # largest local error estimate of the last step, over the bodies
    accumulated: float      # sum of every step's since the start or a reset
    momentum_drift: float   # largest relative |L| drift of the bodies nothing torqued; NaN: none
    energy_drift: float     # the same of their rotational energy
    time: float             # s of simulated time


@dataclass(frozen=True)
class ImuReading:
    """An IMU's latest published reading, in its own (the body's) axes."""

    time: float                     # s of simulated time it was taken at (its stamp)
    frame_id: str
    angular_velocity: np.ndarray     # (3,) rad/s
    linear_acceleration: np.ndarray  # (3,) m/s^2, the specific force
    orientation: np.ndarray          # (4,) (x, y, z, w), body to world; None: not published
    magnetic_field: np.ndarray       # (3,) T; None: the IMU has no magnetometer

    @classmethod
    def from_messages(cls, imu, magnetic_field=None):
        """Build from a sensor_msgs/Imu and, for a magnetometer, its MagneticField."""
        orientation = None
        if imu.orientation_covariance[0] != -1.0:   # REP-145: -1 says "no orientation"
            q = imu.orientation
            orientation = np.array((q.x, q.y, q.z, q.w))
        field = (None if magnetic_field is None
                 else conversions.vector_array(magnetic_field.magnetic_field))
        return cls(conversions.to_seconds(imu.header.stamp), imu.header.frame_id,
                   conversions.vector_array(imu.angular_velocity),
                   conversions.vector_array(imu.linear_acceleration), orientation, field)
