"""Where the LiDAR sits on the robot (base_scan in base_footprint): x, y in m, yaw in rad."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_localization.errors import LocalizationError


@dataclass(frozen=True)
class SensorMount:
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def __post_init__(self) -> None:
        if not all(map(math.isfinite, (self.x, self.y, self.yaw))):
            raise LocalizationError(f"sensor mount: x, y, yaw must be finite, got {self}")

    def sensor_poses(self, particles: np.ndarray) -> np.ndarray:
        """(N, 3) sensor poses in the map frame for (N, 3) robot poses."""
        c, s = np.cos(particles[:, 2]), np.sin(particles[:, 2])
        poses = np.empty_like(particles)
        poses[:, 0] = particles[:, 0] + c * self.x - s * self.y
        poses[:, 1] = particles[:, 1] + s * self.x + c * self.y
        poses[:, 2] = particles[:, 2] + self.yaw
        return poses
