"""Seed 000's beacon localizer (chapter 4, "Localización", with its three improvements).

The pose is tracked by odometry. Each beacon reading (ranges d_i to known
beacons, in their order, and a compass heading) is compared with the ranges
expected from the tracked pose:

    mismatch = sum_i | d_i(pose) - z_i | + | wrap_angle(theta - z_theta) |

and when it exceeds `threshold` the robot relocalizes:

- orientation adjustment ("ajuste de la orientación"): theta is taken from the
  compass rather than kept or searched blindly;
- initial radius from the beacons and a margin ("radio inicial en función de
  las balizas y margen"): the search square is centred on the tracked pose and
  large enough to cover the beacons' bounding box widened by `margin`;
- pyramidal increment ("incremento piramidal"): grid_search.pyramidal_search
  down to `resolution`, instead of the chapter's exhaustive grid.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from amr_localization.beacons import BeaconReading, checked_beacons, range_mismatch
from amr_localization.errors import LocalizationError, OdometryError
from amr_localization.grid_search import SearchResult, exhaustive_search, pyramidal_search
from amr_util.geometry import compose, relative_pose, wrap_angle
from amr_util.parameter_spec import Config, parameter


@dataclass(frozen=True)
class BeaconLocalizerConfig(Config):
    """The beacon_localizer node's tuning (every field live: read at each relocalization)."""

    threshold: float = parameter(0.1, minimum=0.0, maximum=100.0, live=True)
    """mismatch (m + rad) above which the robot relocalizes."""
    margin: float = parameter(0.5, minimum=0.0, maximum=100.0, live=True)
    """m around the beacons' bounding box the first search square covers."""
    resolution: float = parameter(0.005, minimum=0.0001, maximum=1.0, live=True)
    """m, the final grid spacing."""
    half_cells: int = parameter(4, minimum=1, maximum=100, live=True)
    """each pyramid level is a (2 half_cells + 1)^2 grid."""
    pyramidal: bool = parameter(True, live=True)
    """false: the chapter's exhaustive grid at `resolution` (for comparison: slow)."""


@dataclass(frozen=True)
class BeaconUpdate:
    pose: tuple[float, float, float]
    mismatch: float
    """before any relocalization."""
    relocalized: bool
    search: SearchResult | None = None
    search_time: float = 0.0


class BeaconLocalizer:
    def __init__(
        self,
        beacons,
        config: BeaconLocalizerConfig | None = None,
        initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        self.beacons = checked_beacons(beacons)
        self.config = config or BeaconLocalizerConfig()
        if not all(map(math.isfinite, initial_pose)):
            raise LocalizationError(f"initial pose: must be finite, got {initial_pose}")
        self.pose = tuple(float(v) for v in initial_pose)
        self._odometry: tuple[float, float, float] | None = None

    def search_radius(self, centre: tuple[float, float]) -> float:
        """Half side of a square centred on `centre` covering the beacons' bounding box plus the margin."""
        low = self.beacons.min(axis=0) - self.config.margin
        high = self.beacons.max(axis=0) + self.config.margin
        return float(
            max(abs(centre[0] - low[0]), abs(centre[0] - high[0]), abs(centre[1] - low[1]), abs(centre[1] - high[1]))
        )

    def update(self, odometry: tuple[float, float, float], ranges, compass: float) -> BeaconUpdate:
        if len(odometry) != 3 or not all(map(math.isfinite, odometry)):
            raise OdometryError(f"odometry: pose must be 3 finite numbers, got {odometry}")
        reading = BeaconReading.checked(ranges, compass, len(self.beacons))
        self.track(odometry)
        mismatch = self.mismatch(self.pose, reading)
        if mismatch <= self.config.threshold:
            return BeaconUpdate(self.pose, mismatch, False)
        started = time.perf_counter()
        result = self.relocalize(reading)
        return BeaconUpdate(self.pose, mismatch, True, result, time.perf_counter() - started)

    def track(self, odometry: tuple[float, float, float]) -> tuple[float, float, float]:
        """Move the pose by the odometry increment since the last call (also when a reading is unusable)."""
        if len(odometry) != 3 or not all(map(math.isfinite, odometry)):
            raise OdometryError(f"odometry: pose must be 3 finite numbers, got {odometry}")
        odometry = tuple(float(v) for v in odometry)
        if self._odometry is not None:
            moved = relative_pose(self._odometry, odometry)
            self.pose = tuple(compose(np.array([self.pose]), moved)[0])
        self._odometry = odometry
        return self.pose

    def mismatch(self, pose: tuple[float, float, float], reading: BeaconReading) -> float:
        ranges = range_mismatch(np.array([pose[:2]]), self.beacons, reading)[0]
        return float(ranges + abs(float(wrap_angle(pose[2] - reading.compass))))

    def relocalize(self, reading: BeaconReading, pyramidal: bool | None = None) -> SearchResult:
        """Grid search around the tracked pose; heading from the compass. Updates and returns the pose found."""
        centre = self.pose[:2]
        radius = self.search_radius(centre)

        def cost(points: np.ndarray) -> np.ndarray:
            return range_mismatch(points, self.beacons, reading)

        use_pyramid = self.config.pyramidal if pyramidal is None else pyramidal
        if use_pyramid:
            result = pyramidal_search(cost, centre, radius, self.config.resolution, self.config.half_cells)
        else:
            result = exhaustive_search(cost, centre, radius, self.config.resolution)
        self.pose = (float(result.position[0]), float(result.position[1]), float(wrap_angle(reading.compass)))
        return result
