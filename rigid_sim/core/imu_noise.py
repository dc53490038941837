# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""IMU noise: white noise plus a drifting bias per axis, seeded and reproducible.

The parameters are named as in Gazebo's IMU noise model, per sensor (gyro, accel), the same
for its three axes, which draw independently:

``stddev``                           white noise of one reading (rad/s or m/s^2)
``bias_mean``, ``bias_stddev``       turn-on bias, drawn once per axis: mean + N(0, stddev)
``dynamic_bias_stddev``              density of the bias drift sigma_b (units/sqrt(s))
``dynamic_bias_correlation_time``    tau (s); absent: a random walk, var(drift) = sigma_b^2 t;
                                     given: first-order Gauss-Markov, stationary variance
                                     sigma_b^2 tau / 2, which is a random walk for t << tau

The drift is propagated exactly over each interval between two readings, so its statistics
do not depend on the IMU's rate.
"""
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SensorNoise:
    """Noise parameters of one three-axis sensor; see the module text for their meaning."""

    stddev: float = 0.0
    bias_mean: float = 0.0
    bias_stddev: float = 0.0
    dynamic_bias_stddev: float = 0.0
    dynamic_bias_correlation_time: float = math.inf

    @property
    def variance(self):
        """Variance of the white noise of one reading, per axis."""
        return self.stddev ** 2


class NoisySensor:
    """One sensor's bias state and random stream; :meth:`read` adds noise to exact values.

    Parameters
    ----------
    noise : SensorNoise
        White-noise and bias parameters of the sensor.
    rng : numpy.random.Generator
        This sensor's own random stream.
    """

    def __init__(self, noise, rng):
        self.noise = noise
        self._rng = rng
        self.turn_on_bias = noise.bias_mean + noise.bias_stddev * rng.standard_normal(3)
        self.drift = np.zeros(3)   # the dynamic part of the bias, 0 at turn-on

    @property
    def bias(self):
        """(3,) the bias now: turn-on bias plus drift."""
        return self.turn_on_bias + self.drift

    def read(self, exact, interval):
        """``exact`` (3,) plus the bias after ``interval`` s more of drift, plus white noise."""
        noise = self.noise
        if noise.dynamic_bias_stddev > 0.0 and interval > 0.0:
            self.drift = self._drifted(interval)
        return exact + self.bias + noise.stddev * self._rng.standard_normal(3)

    def _drifted(self, interval):
        sigma, tau = self.noise.dynamic_bias_stddev, self.noise.dynamic_bias_correlation_time
        if math.isinf(tau):
            return self.drift + sigma * math.sqrt(interval) * self._rng.standard_normal(3)
        # Exact discretisation of db = -b / tau dt + sigma dW over the interval.
        decay = math.exp(-interval / tau)
        spread = sigma * math.sqrt(-0.5 * tau * math.expm1(-2.0 * interval / tau))
        return decay * self.drift + spread * self._rng.standard_normal(3)
