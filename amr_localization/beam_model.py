"""Beam measurement model (Thrun et al., table 6.1; AMCL's "beam"), ranges predicted by ray casting.

Each particle's expected range z*_k per beam comes from amr_maps'
NumpyRayCaster over the outline of the map's occupied cells (+inf where no
wall is in range is read as range_max). A reading z_k then scores

    p(z_k | x) = z_hit N(z_k; z*_k, sigma_hit)
               + z_short lambda_short exp(-lambda_short z_k)   (only z_k < z*_k: something in the way)
               + z_max [z_k = range_max]                         (no return: REP 117 +inf)
               + z_rand / range_max

One ray fan per particle makes this model much slower than the likelihood field
(about 0.1 ms a particle): it is the option for few particles and for checking
the likelihood field against the textbook model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_localization.distance_field import DistanceField
from amr_localization.errors import LocalizationError
from amr_localization.scan_beams import Beams
from amr_localization.sensor_mount import SensorMount
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import world_from_dict


@dataclass(frozen=True)
class BeamModelParams:
    sigma_hit: float = 0.05
    lambda_short: float = 0.1
    z_hit: float = 0.8
    z_short: float = 0.05
    z_max: float = 0.05
    z_rand: float = 0.1

    def __post_init__(self) -> None:
        for name in ("sigma_hit", "lambda_short"):
            value = getattr(self, name)
            if not math.isfinite(value) or value <= 0.0:
                raise LocalizationError(f"{name}: must be a positive number, got {value!r}")
        for name in ("z_hit", "z_short", "z_max", "z_rand"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0.0:
                raise LocalizationError(f"{name}: must be a number >= 0, got {value!r}")


def map_faces(field: DistanceField) -> np.ndarray:
    """(F, 4) wall faces around the map's occupied cells, through the simulator's own grid worlds."""
    grid = field.grid
    occupied = field.distances == 0.0
    rows = ["".join("#" if cell else "." for cell in row) for row in occupied[::-1]]
    world = world_from_dict(
        {
            "grid": {"cell_size": grid.resolution, "origin": list(grid.origin[:2]), "rows": rows},
            "start": [0.0, 0.0, 0.0],
        }
    )
    return world.faces


class MapRays:
    """The range each selected beam would read on the map from one sensor pose: the outline of the map's occupied
    cells, ray cast (range_max where nothing is in range; everywhere on a map without an occupied cell)."""

    def __init__(self, field: DistanceField) -> None:
        self._caster = NumpyRayCaster(map_faces(field)) if (field.distances == 0.0).any() else None

    def expected_ranges(self, sensor: np.ndarray, beams: Beams) -> np.ndarray:
        """(K,) m per selected beam from the sensor pose (x, y, theta): one fan over the selected span."""
        if self._caster is None or beams.ranges.size == 0:
            return np.full(beams.ranges.size, float(beams.range_max))
        span = int(beams.steps[-1]) + 1
        increment = beams.angle_increment if span > 1 else 1.0
        if increment > 0.0:
            fan = self._caster.cast(sensor[0], sensor[1], sensor[2] + beams.angles[0], increment, span, beams.range_max)
        else:  # a clockwise scan: cast the same fan counter-clockwise from its last beam
            first = sensor[2] + beams.angles[-1]
            fan = self._caster.cast(sensor[0], sensor[1], first, -increment, span, beams.range_max)[::-1]
        return np.minimum(fan[beams.steps], beams.range_max)


class BeamModel:
    """log p(scan | pose) by ray casting every particle's beams."""

    def __init__(self, field: DistanceField, params: BeamModelParams, mount: SensorMount) -> None:
        if not (field.distances == 0.0).any():
            raise LocalizationError("map: the beam model needs at least one occupied cell to cast rays at")
        self.params = params
        self.mount = mount
        self._rays = MapRays(field)

    def expected_ranges(self, sensor: np.ndarray, beams: Beams) -> np.ndarray:
        """Predicted range per selected beam from one sensor pose (MapRays)."""
        return self._rays.expected_ranges(sensor, beams)

    def log_likelihood(self, particles: np.ndarray, beams: Beams, weights: np.ndarray | None = None) -> np.ndarray:
        """(N,) sum over the beams of w_k log p(z_k | particle) (w_k = 1 without `weights`; a beam without a
        return, which the beam model scores by its max term, weighs as much as the mean returned beam)."""
        p = self.params
        if beams.ranges.size == 0:
            return np.zeros(len(particles))
        sensors = self.mount.sensor_poses(particles)
        expected = np.array([self.expected_ranges(pose, beams) for pose in sensors])
        z = beams.ranges[None, :]
        hit = p.z_hit * np.exp(-0.5 * ((z - expected) / p.sigma_hit) ** 2) / (p.sigma_hit * math.sqrt(2.0 * math.pi))
        short = np.where(z < expected, p.z_short * p.lambda_short * np.exp(-p.lambda_short * z), 0.0)
        maximum = np.where(beams.returned, 0.0, p.z_max)[None, :]
        density = hit + short + maximum + p.z_rand / beams.range_max
        if weights is None:
            return np.log(density).sum(axis=1)
        weights = np.asarray(weights, float)
        mean = float(weights[beams.returned].mean()) if beams.returned.any() else 1.0
        return np.log(density) @ np.where(beams.returned, weights, mean)
