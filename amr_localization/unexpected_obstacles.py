"""Readings much shorter than the map allows: something that is not on the map stands in front (issue 22).

Another robot, a person, a box: the LiDAR returns from it, short of the wall the map has on that beam. To the
likelihood field such an end point is an outlier, but not a harmless one: it scores low at the true pose (it lies
in free space) and can score well at a pose shifted so that it lands near a wall, so a scan a fifth of which ends
on other robots pulls the particles off the truth; and the scan-fit test (scan_fit.py), which asks what share of
the beams ends on a wall, reads such a scan as not fitting, so `localized` is never declared and, after
`lost_updates`, global localization restarts (measured: docs/fleet.md).

The beam model's answer (Thrun et al., table 6.1: z_short, an exponential of unexpected obstacles in front of the
expected range) needs the expected range of every beam at every particle. This module asks it at one pose, the
filter's estimate, once one hypothesis holds the weight (and, while a withdrawal is contested, at every cluster
heavy enough to block a declaration): `MapRanges.expected` ray casts each beam on the map (the
beam model's `MapRays`: the outline of the occupied cells), and `without_unexpected` drops the
returned beams reading `margin` m or more short of it, unless more than `max_share` of them do (then the estimate,
not the world, is what is wrong: a kidnapped robot; nothing is dropped).
"""

from __future__ import annotations

import numpy as np

from amr_localization.beam_model import MapRays
from amr_localization.distance_field import DistanceField
from amr_localization.scan_beams import Beams
from amr_localization.sensor_mount import SensorMount


class MapRanges:
    """The range each beam would read on the map from a robot pose (no noise, nothing but the map)."""

    def __init__(self, field: DistanceField, mount: SensorMount) -> None:
        self.mount = mount
        self._rays = MapRays(field)

    def expected(self, pose: np.ndarray, beams: Beams) -> np.ndarray:
        """(K,) m for the selected beams from robot pose (x, y, theta); range_max where the map has nothing within
        range."""
        sensor = self.mount.sensor_poses(np.asarray(pose, dtype=float).reshape(1, 3))[0]
        return self._rays.expected_ranges(sensor, beams)


def subset(beams: Beams, keep: np.ndarray) -> Beams:
    """The beams where `keep` is true (a model weighs what it is given: a dropped beam says nothing)."""
    return Beams(beams.ranges[keep], beams.angles[keep], beams.returned[keep], beams.range_max, beams.steps[keep],
                 beams.angle_increment)


def unexpected(map_ranges: MapRanges, pose: np.ndarray, beams: Beams, margin: float) -> np.ndarray:
    """(K,) True for the returned beams reading `margin` m or more short of the map's range at `pose`."""
    if not beams.returned.any():
        return np.zeros(len(beams.ranges), dtype=bool)
    expected = map_ranges.expected(pose, beams)
    return beams.returned & (beams.ranges <= expected - margin)


def without_unexpected(map_ranges: MapRanges, pose: np.ndarray, beams: Beams, margin: float,
                       max_share: float) -> tuple[Beams, int]:
    """`beams` without those reading `margin` m or more short of the map at `pose` (x, y, theta), or at any of
    several poses ((P, 3): a beam short at one of the places weighed says nothing between them), and how many
    were dropped; all of them (and 0) when more than `max_share` of the returned beams read short."""
    short = np.zeros(len(beams.ranges), dtype=bool)
    for one in np.asarray(pose, dtype=float).reshape(-1, 3):
        short |= unexpected(map_ranges, one, beams, margin)
    count = int(np.count_nonzero(short))
    if count == 0 or count > max_share * int(np.count_nonzero(beams.returned)):
        return beams, 0
    return subset(beams, ~short), count
