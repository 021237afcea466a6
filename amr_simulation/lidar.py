"""A 2D LiDAR: ray casting plus range limits, Gaussian noise and REP 117 special values."""

from __future__ import annotations

import numpy as np

from amr_maps.raycast import NumpyRayCaster
from amr_simulation.config import LidarConfig
from amr_simulation.raycast import PymunkRayCaster
from amr_util.geometry import Pose2D, compose


class Lidar:
    """Scans from a robot pose; ranges follow sensor_msgs/LaserScan and REP 117.

    A return closer than range_min reads -inf, no return within range_max reads
    +inf; the others get N(0, noise_std) noise, kept within [range_min, range_max].
    """

    def __init__(self, config: LidarConfig, caster: NumpyRayCaster | PymunkRayCaster, rng: np.random.Generator) -> None:
        self.config = config
        self._caster = caster
        self._rng = rng

    def sensor_pose(self, robot: Pose2D) -> Pose2D:
        """Where the sensor is, in the world frame."""
        return compose(robot, Pose2D(self.config.x, self.config.y, 0.0))

    def true_ranges(self, robot: Pose2D) -> np.ndarray:
        """Noise-free distances to the first wall per beam (+inf for none; beyond range_max, maybe a distance)."""
        sensor = self.sensor_pose(robot)
        c = self.config
        return self._caster.cast(
            sensor.x, sensor.y, sensor.theta + c.angle_min, c.angle_increment, c.beams, c.range_max
        )

    def scan(self, robot: Pose2D) -> np.ndarray:
        """One noisy scan; always draws one normal sample per beam, so streams stay aligned."""
        return readings(self.true_ranges(robot), self.noise(), self.config)

    def noise(self) -> np.ndarray | None:
        """One scan's range noise (beams,) from this LiDAR's stream, None when noise_std is 0."""
        c = self.config
        return self._rng.normal(0.0, c.noise_std, c.beams) if c.noise_std > 0.0 else None


def readings(ranges: np.ndarray, noise: np.ndarray | None, config: LidarConfig) -> np.ndarray:
    """What LiDARs read from true ranges (..., beams) plus their noise (same shape, or None)."""
    c = config
    out = ranges + noise if noise is not None else ranges.copy()
    np.minimum(np.maximum(out, c.range_min, out=out), c.range_max, out=out)
    out[ranges > c.range_max] = np.inf
    out[ranges < c.range_min] = -np.inf
    return out
