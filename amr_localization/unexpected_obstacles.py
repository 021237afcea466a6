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

Dropping them has a price: a place that is not the robot's can explain what is left. Robots standing close
around one fill a quarter of its scan, and where a look-alike place has walls their bodies read short and are
dropped, the rest fitting the place well. The other side of the same rule catches it: nothing unmapped makes a
beam *longer*, so `seen_through` counts the beams reading far beyond the map's range at the estimate (through a
wall of the map); the filter declares no place where more than a few do (particle_filter.py).
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
        self.resolution = float(field.grid.resolution)
        """m, the map's cell: how far in front of a wall its outline may lie."""
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


def seen_through(map_ranges: MapRanges, pose: np.ndarray, beams: Beams, margin: float,
                 tolerance: tuple[float, float]) -> np.ndarray:
    """(K,) True for the returned beams reading `margin` m or more *beyond* the map's range at `pose` (x, y,
    theta) and at every pose within `tolerance` (m, rad) of it: beams that went through a wall of the map.

    Something not on the map only shortens a beam, so at the true pose (and a map that is right) no beam reads
    far beyond the map's range; at a look-alike place the other robots made plausible (their bodies standing
    where the place has walls, the beams reading short there dropped as unexpected) some do. Two things make a
    beam at a right pose read beyond the map's range, and both are allowed for:

    - the pose is only known to the declaration limits: a beam grazing a corner reads far beyond it at a pose a
      degree off. The map's range is the longest over the poses `tolerance` apart on each axis around `pose`
      (3 x 3 x 3 of them);
    - the map's walls are only known to a cell (the ray cast ends on the outline of the occupied cells, up to a
      cell in front of the wall): at incidence alpha to the wall that is up to resolution / sin(alpha) along
      the beam. On a flat wall r(phi) = d / sin(alpha), so dr/dphi = -r cot(alpha) and
      1 / sin(alpha) = sqrt(1 + (r' / r)^2), r' taken between neighbouring beams at `pose`: a beam nearly along
      a wall (or at a corner, where r jumps) is allowed a long way."""
    if not beams.returned.any():
        return np.zeros(len(beams.ranges), dtype=bool)
    position, heading = tolerance
    centre = np.asarray(pose, dtype=float).reshape(3)
    at_pose = map_ranges.expected(centre, beams)
    longest = at_pose
    for dx in (-position, 0.0, position):
        for dy in (-position, 0.0, position):
            for dtheta in (-heading, 0.0, heading):
                if dx or dy or dtheta:  # the pose itself is cast once, above
                    longest = np.maximum(longest, map_ranges.expected(centre + np.array([dx, dy, dtheta]), beams))
    if len(at_pose) > 1:
        slope = np.gradient(at_pose, beams.steps * beams.angle_increment)
        cell = map_ranges.resolution * np.sqrt(1.0 + (slope / np.maximum(at_pose, 1e-6)) ** 2)
    else:
        cell = np.full(len(at_pose), map_ranges.resolution)
    return beams.returned & (beams.ranges >= longest + margin + cell)
