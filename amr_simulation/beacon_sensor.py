"""Range beacons and a compass (seed 000's sense()): the noisy distance from the robot to each beacon
of the world, in the world's order, and its noisy heading.

    z_i     = || (x, y) - b_i || + N(0, range_noise_std), clipped at 0
    z_theta = wrap(theta + N(0, compass_noise_std))
"""

from __future__ import annotations

import numpy as np

from amr_simulation.config import BeaconConfig
from amr_util.geometry import Pose2D, wrap_angle


class BeaconSensor:
    def __init__(self, beacons, config: BeaconConfig, rng: np.random.Generator) -> None:
        self.positions = np.asarray(beacons, dtype=float).reshape(-1, 2)
        self.config = config
        self._rng = rng

    def measure(self, pose: Pose2D) -> tuple[np.ndarray, float]:
        """(ranges (one per beacon, m), compass heading (rad))."""
        ranges = np.hypot(self.positions[:, 0] - pose.x, self.positions[:, 1] - pose.y)
        ranges = np.maximum(ranges + self._rng.normal(0.0, self.config.range_noise_std, len(ranges)), 0.0)
        compass = wrap_angle(pose.theta + self._rng.normal(0.0, self.config.compass_noise_std))
        return ranges, float(compass)
