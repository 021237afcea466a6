"""Readings much shorter than the map allows: something that is not on the map stands in front (issue 22).

Another robot, a person, a box: the LiDAR returns from it, short of the wall the map has on that beam. To the
likelihood field such an end point is an outlier, but not a harmless one: it scores low at the true pose (it lies
in free space) and can score well at a pose shifted so that it lands near a wall, so a scan a fifth of which ends
on other robots pulls the particles off the truth; and the scan-fit test (scan_fit.py), which asks what share of
the beams ends on a wall, reads such a scan as not fitting, so `localized` is never declared and, after
`lost_updates`, global localization restarts (measured: docs/fleet.md).

The beam model's answer (Thrun et al., table 6.1: z_short, an exponential of unexpected obstacles in front of the
expected range) needs the expected range of every beam at every particle. This module asks it at one pose, the
filter's estimate, once one hypothesis holds the weight: `MapRanges.expected` traces each beam on the distance
field (sphere tracing: steps of the distance to the nearest occupied cell), and `without_unexpected` drops the
returned beams reading `margin` m or more short of it, unless more than `max_share` of them do (then the estimate,
not the world, is what is wrong: a kidnapped robot; nothing is dropped).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from amr_localization.distance_field import DistanceField
from amr_localization.scan_beams import Beams
from amr_localization.sensor_mount import SensorMount


class MapRanges:
    """The range each beam would read on the map from a pose (no noise, nothing but the map)."""

    def __init__(self, field: DistanceField, mount: SensorMount) -> None:
        grid = field.grid
        self.mount = mount
        self._resolution = grid.resolution
        self._origin = np.asarray(grid.origin[:2], dtype=float)
        cells = np.minimum(field.distances / grid.resolution, 1e6)  # cells to the nearest occupied cell centre
        self._cells = np.ascontiguousarray(cells, dtype=np.float32)

    def expected(self, pose: np.ndarray, angles: np.ndarray, range_max: float) -> np.ndarray:
        """(K,) m for the beams at `angles` (sensor frame) from robot pose (x, y, theta); range_max where the
        map has nothing within range (or the beam leaves the map)."""
        sensor = self.mount.sensor_poses(np.asarray(pose, dtype=float).reshape(1, 3))[0]
        col = (sensor[0] - self._origin[0]) / self._resolution
        row = (sensor[1] - self._origin[1]) / self._resolution
        out = np.empty(len(angles))
        _trace(self._cells, col, row, sensor[2] + np.asarray(angles, dtype=float), range_max / self._resolution, out)
        return np.minimum(out * self._resolution, range_max)


@numba.njit(cache=True)
def _trace(cells, col0, row0, headings, max_cells, out):
    """out[k]: cells travelled along heading k from (col0, row0) until an occupied cell (or max_cells, or the
    map's edge). Steps of the distance to the nearest occupied cell centre less one cell, at least half a cell."""
    rows, cols = cells.shape
    for k in range(headings.shape[0]):
        c, s = math.cos(headings[k]), math.sin(headings[k])
        t = 0.0
        out[k] = max_cells
        while t < max_cells:
            col = col0 + c * t
            row = row0 + s * t
            if col < 0.0 or row < 0.0 or col >= cols or row >= rows:
                break
            distance = cells[int(row), int(col)]
            if distance == 0.0:
                out[k] = t
                break
            t += max(distance - 1.0, 0.5)


def subset(beams: Beams, keep: np.ndarray) -> Beams:
    """The beams where `keep` is true (a model weighs what it is given: a dropped beam says nothing)."""
    return Beams(beams.ranges[keep], beams.angles[keep], beams.returned[keep], beams.range_max, beams.steps[keep],
                 beams.angle_increment)


def unexpected(map_ranges: MapRanges, pose: np.ndarray, beams: Beams, margin: float) -> np.ndarray:
    """(K,) True for the returned beams reading `margin` m or more short of the map's range at `pose`."""
    if not beams.returned.any():
        return np.zeros(len(beams.ranges), dtype=bool)
    expected = map_ranges.expected(pose, beams.angles, beams.range_max)
    return beams.returned & (beams.ranges <= expected - margin)


def without_unexpected(map_ranges: MapRanges, pose: np.ndarray, beams: Beams, margin: float,
                       max_share: float) -> tuple[Beams, int]:
    """`beams` without those reading `margin` m or more short of the map at `pose`, and how many were dropped;
    all of them (and 0) when more than `max_share` of the returned beams read short."""
    short = unexpected(map_ranges, pose, beams, margin)
    count = int(np.count_nonzero(short))
    if count == 0 or count > max_share * int(np.count_nonzero(beams.returned)):
        return beams, 0
    return subset(beams, ~short), count
