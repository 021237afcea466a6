"""How well one pose explains a scan: the share of returned beams ending within `distance` of a wall.

A check independent of the particle weights: after a kidnapping the particles may
still agree with each other (one tight cluster) while the scan no longer fits
where they are; the share of beams landing on walls then drops.
"""

from __future__ import annotations

import numpy as np

from amr_localization.distance_field import DistanceField
from amr_localization.scan_beams import Beams
from amr_localization.sensor_mount import SensorMount


def scan_fit(field: DistanceField, mount: SensorMount, pose: np.ndarray, beams: Beams, distance: float) -> float:
    """Share in [0, 1] of the returned beams whose end point is within `distance` m of an occupied cell."""
    use = beams.returned
    if not use.any():
        return 0.0
    sensor = mount.sensor_poses(np.asarray(pose, dtype=float)[None, :])[0]
    angles = sensor[2] + beams.angles[use]
    x = sensor[0] + beams.ranges[use] * np.cos(angles)
    y = sensor[1] + beams.ranges[use] * np.sin(angles)
    row, col = field.grid.world_to_cell(x, y)
    inside = field.grid.inside(row, col)
    near = np.zeros(x.shape, dtype=bool)
    near[inside] = field.distances[row[inside], col[inside]] <= distance
    return float(near.mean())
