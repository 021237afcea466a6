"""Distances a wall follower needs, read from a 2D LiDAR scan by beam angle.

Beams are located by their angle (``angle_min + i * angle_increment``,
counter-clockwise, 0 straight ahead, REP 103), never by index counts, so the
same code serves the simulated 240-beam sensor and the real 360-beam LDS with
any ``angle_min``. Readings follow sensor_msgs/LaserScan and REP 117:

* a finite reading within [range_min, range_max] is a measurement;
* ``+inf`` means no return within range: free space;
* ``-inf`` means an object closer than ``range_min``: counted as ``range_min``;
* NaN, and finite readings outside [range_min, range_max] (the LDS writes 0.0
  for a failed beam), are ignored, as the seed's ``_safe_min`` did.

A sector with no usable reading reads ``+inf`` (the seed's default of "far").
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from amr_control import scan_kernels
from amr_util.scan import ScanData


@dataclass(frozen=True)
class Sectors:
    """Angular windows (rad): a centre and a half width each, counter-clockwise from ahead."""

    front_half_width: float
    side_half_width: float
    """the wide side windows: their minimum is the distance to a wall even when the robot is skewed"""
    abeam_half_width: float
    """the narrow windows to the sides (and straight ahead): a wall is there only if they see it,
    so a corner point seen obliquely by a wide window does not hide an opening"""
    left_center: float = 0.5 * math.pi
    right_center: float = -0.5 * math.pi
    direction_half_width: float | None = None
    """the side windows whose fitted lines give the walls' direction (None: the side windows). A
    short piece of wall gives a poor direction under range noise: 0.175 m from a wall at 3 cm
    noise, +-20 deg scatter by 16 deg (standard deviation), +-40 deg by 3 deg."""


@dataclass(frozen=True)
class Footprint:
    """A disc robot and where its LiDAR sits (m, robot frame, x ahead)."""

    radius: float
    lidar_x: float = 0.0
    """on the robot's centre line, lidar_x ahead of the rotation centre (negative: behind)"""
    side_margin: float = 0.0
    """widens the swept band on each side: a real path curves a little (slip, noise)"""


@dataclass(frozen=True)
class LineFit:
    """A straight wall fitted to the returns of a side window (total least squares)."""

    distance: float
    """m, from the LiDAR to the fitted line."""
    angle: float
    """rad, the line's direction in the robot frame, in (-pi/2, pi/2]: 0 = parallel to the heading,
    positive = the wall runs counter-clockwise of the heading (the robot is turned clockwise of it)."""
    rms: float
    """m, root mean square distance of the returns from the line."""
    angle_std: float = 0.0
    """rad, standard error of ``angle``: rms over the root of the returns' squared spread along the line
    (a short window of noisy returns gives a poor direction: 0.3 m of wall at 3 cm noise, about 9 deg)."""


@dataclass(frozen=True)
class Readings:
    """What one scan says; distances in m from the LiDAR, inf when nothing is seen."""

    front: float
    ahead: float
    """the narrow window straight ahead (abeam width): the way a turn may end on"""
    left: float
    right: float
    left_abeam: float
    right_abeam: float
    left_fit: LineFit | None
    right_fit: LineFit | None
    """None when a side window holds fewer than MIN_FIT_POINTS returns."""
    clearance: float
    """Free travel straight ahead before the footprint would touch a return."""
    clearance_side: float
    """+1 if the return limiting clearance is on the left, -1 on the right, 0 if none."""
    usable_beams: int
    """Beams that carried a measurement or a REP 117 +-inf."""
    window_beams: tuple[int, int, int]
    """(front, left abeam, right abeam): beams inside the narrowest windows (0 = scan too coarse)."""
    left_direction_fit: LineFit | None = None
    right_direction_fit: LineFit | None = None
    """The side walls fitted over the direction windows (Sectors.direction_half_width)."""


class _Geometry:
    """Everything about one beam layout (count, angle_min, increment) that does not change per scan.

    The six windows are stored back to back in one index array, so one gather and one
    ``np.minimum.reduceat`` give all their minima.
    """

    def __init__(self, count: int, angle_min: float, increment: float, sectors: Sectors, footprint: Footprint) -> None:
        angles = angle_min + increment * np.arange(count)
        wrapped = np.arctan2(np.sin(angles), np.cos(angles))
        self.angles = wrapped
        self.full_circle = abs(increment) * count >= 2.0 * math.pi - 1e-6
        cos, sin = np.cos(wrapped), np.sin(wrapped)
        self.cos, self.sin = cos, sin

        def window(center: float, half: float) -> np.ndarray:
            offset = np.arctan2(np.sin(wrapped - center), np.cos(wrapped - center))
            return np.flatnonzero(np.abs(offset) <= half + 1e-9)

        windows = [
            window(0.0, sectors.front_half_width),  # front
            window(0.0, sectors.abeam_half_width),  # ahead
            window(sectors.left_center, sectors.side_half_width),  # left
            window(sectors.right_center, sectors.side_half_width),  # right
            window(sectors.left_center, sectors.abeam_half_width),  # left abeam
            window(sectors.right_center, sectors.abeam_half_width),  # right abeam
        ]
        self.sizes = [w.size for w in windows]
        self.gather = np.concatenate(windows)
        bounds = np.cumsum([0] + self.sizes)
        self.slices = [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds)]
        self.nonempty = [i for i, size in enumerate(self.sizes) if size]
        self.starts = bounds[:-1][self.nonempty]
        # Unit vectors of the side windows, for the line fits.
        self.left_cs = (cos[windows[2]], sin[windows[2]])
        self.right_cs = (cos[windows[3]], sin[windows[3]])
        # Beams averaged for the window minima: MINIMUM_MEAN_ANGLE either side (none on a coarse scan).
        # (At most MAX_MEAN_BEAMS and never more than the scan holds: a scan of absurdly fine
        # increment must not make the average a window of millions of beams.)
        half = min(
            int(MINIMUM_MEAN_ANGLE / max(abs(increment), 1e-9) + 1e-9), MAX_MEAN_BEAMS // 2, max(count - 1, 0) // 2
        )
        self.mean_beams = 2 * half + 1
        wide = sectors.side_half_width if sectors.direction_half_width is None else sectors.direction_half_width
        self.directions = [window(center, wide) for center in (sectors.left_center, sectors.right_center)]
        self.direction_cs = [(cos[w], sin[w]) for w in self.directions]
        # Forward beams, and the range below which each one's return lies in the swept band |y| < R.
        forward = np.flatnonzero(cos > 0.0)
        self.forward = forward
        self.forward_cos, self.forward_sin = cos[forward], sin[forward]
        with np.errstate(divide="ignore", over="ignore"):  # sin = 0 straight ahead: no limit
            self.band_limit = (footprint.radius + footprint.side_margin) / np.abs(sin[forward])


MAX_RANGE = 1000.0
"""m: readings beyond this are never measurements, whatever range_max says."""


class SectorReader:
    """Turns scans into :class:`Readings`; caches the beam layout between scans."""

    def __init__(self, sectors: Sectors, footprint: Footprint, median_beams: int = 1) -> None:
        if median_beams < 1 or median_beams % 2 == 0:
            raise ValueError(f"median_beams must be a positive odd number, got {median_beams}")
        self.sectors = sectors
        self.footprint = footprint
        self.median_beams = median_beams
        self._key: tuple[Any, ...] | None = None
        self._geometry: _Geometry | None = None
        self._ranges: np.ndarray | None = None  # the last scan, cleaned, for nearest
        self._smoothed: np.ndarray | None = None  # and averaged on surfaces, for min_around and free_travel

    def read(self, scan: ScanData) -> Readings | str:
        """Window minima, side line fits and straight-ahead clearance, or what makes the scan unusable."""
        try:
            raw = np.asarray(scan.ranges, dtype=float)
            angle_min, increment = float(scan.angle_min), float(scan.angle_increment)
            range_min, range_max = float(scan.range_min), float(scan.range_max)
        except (TypeError, ValueError) as error:
            return f"unreadable scan ({error})"
        if raw.ndim != 1 or raw.size == 0:
            return f"ranges must be a non-empty list, got shape {raw.shape}"
        if not (math.isfinite(angle_min) and math.isfinite(increment)):
            return f"non-finite angle_min {angle_min} or angle_increment {increment}"
        if increment == 0.0 and raw.size > 1:
            return "angle_increment is 0"
        if not math.isfinite(angle_min + increment * (raw.size - 1)):
            return f"beam angles overflow (angle_min {angle_min}, angle_increment {increment})"
        geometry = self._layout(raw.size, angle_min, increment)
        range_min = range_min if math.isfinite(range_min) and range_min > 0.0 else 0.0
        # NaN compares False; no planar LiDAR reads beyond MAX_RANGE, larger values are corrupt.
        range_max = min(range_max, MAX_RANGE) if range_max > range_min else MAX_RANGE
        # Ignored readings (NaN, out of range) become +inf: they never lower a minimum; -inf reads range_min.
        if not (raw.flags.writeable and raw.flags.c_contiguous):  # one compiled variant (a simulator's are read-only)
            raw = np.array(raw)
        ranges, usable = scan_kernels.clean(raw, range_min, range_max)
        if self.median_beams > 1:
            ranges = _running_median(ranges, self.median_beams, geometry.full_circle)

        # Window minima read the ranges averaged within MINIMUM_MEAN_ANGLE on one surface: the
        # minimum of 20 noisy beams lies about 2 sigma short (6 cm at 3 cm LiDAR noise), which put
        # every turn that early. The line fits take the beams as they are (a fit averages anyway).
        smoothed = _running_mean(ranges, CLEARANCE_MEAN_BEAMS, geometry.full_circle)
        averaged = _flat_mean(ranges, geometry.mean_beams, increment, geometry.full_circle)
        minima = [math.inf] * 6
        if geometry.nonempty:
            for index, value in zip(
                geometry.nonempty, np.minimum.reduceat(averaged[geometry.gather], geometry.starts), strict=True
            ):
                minima[index] = float(value)
        front, ahead, left, right, left_abeam, right_abeam = minima
        gathered = ranges[geometry.gather]
        left_fit = _fit_line(gathered[geometry.slices[2]], *geometry.left_cs)
        right_fit = _fit_line(gathered[geometry.slices[3]], *geometry.right_cs)
        left_wide, right_wide = (
            _fit_line(ranges[w], *cs) for w, cs in zip(geometry.directions, geometry.direction_cs, strict=True)
        )
        clearance, side = self._clearance(smoothed, geometry)
        sizes = (geometry.sizes[0], geometry.sizes[4], geometry.sizes[5])
        self._ranges, self._smoothed = ranges, averaged
        return Readings(
            front,
            ahead,
            left,
            right,
            left_abeam,
            right_abeam,
            left_fit,
            right_fit,
            clearance,
            side,
            usable,
            sizes,
            left_wide,
            right_wide,
        )

    def min_around(self, center: float, half_width: float) -> float:
        """The last read scan's minimum within half_width of the direction center (rad), read as the
        window minima are (averaged on surfaces); inf if none."""
        if self._smoothed is None:
            return math.inf
        angles = self._geometry.angles  # type: ignore[union-attr]
        inside = np.abs(np.arctan2(np.sin(angles - center), np.cos(angles - center))) <= half_width + 1e-9
        return float(self._smoothed[inside].min()) if inside.any() else math.inf

    def nearest(self) -> tuple[float, float]:
        """(bearing rad, range m) of the last read scan's nearest return; (0, inf) if none."""
        if self._ranges is None or self._geometry is None or not np.isfinite(self._ranges).any():
            return 0.0, math.inf
        index = int(np.argmin(self._ranges))
        return float(self._geometry.angles[index]), float(self._ranges[index])

    def wall_end(self, side: float, distance: float, skew: float) -> float | None:
        """Where a side wall that the robot has just passed the end of ends, or None if not seen.

        ``side``: +1 left, -1 right; ``distance``: the wall's distance from the LiDAR (its last
        fit); ``skew``: the heading error against the walls (LineFit.angle convention). The
        returns are turned into the walls' frame (x along the walls, rotation centre at 0); those
        within WALL_END_BAND of the wall's line split into runs where consecutive ones lie further
        than WALL_END_GAP apart along it; the passed wall is the last run that ends before the
        LiDAR, and its last return (its end face included) gives the x returned. A wall resuming
        beyond an opening lies further on the same line and ends ahead of the robot, if at all. Range noise moves these
        returns mostly across the line, so the end is read to about a centimetre, where a window
        abeam reads it only when its last beam has passed it (later still when the robot is
        skewed towards the wall).
        """
        if self._ranges is None or self._geometry is None or not math.isfinite(distance):
            return None
        along, across, lidar = self._walls_frame(self._ranges, skew)
        on_line = (np.abs(across - side * distance) < WALL_END_BAND) & (np.abs(along - lidar) < WALL_END_REACH)
        along = np.sort(along[on_line])
        if along.size == 0:
            return None
        ends = along[np.append(np.flatnonzero(np.diff(along) > WALL_END_GAP), along.size - 1)]
        passed = ends[ends <= lidar + WALL_END_SLACK]
        return float(passed[-1]) if passed.size else None

    def _walls_frame(self, ranges: np.ndarray, skew: float) -> tuple[np.ndarray, np.ndarray, float]:
        """(along, across, lidar): the finite returns of ``ranges`` turned by -skew into the walls' frame
        (rotation centre at 0), and the LiDAR's place along them."""
        seen = ranges < np.inf
        r = ranges[seen]
        x = self.footprint.lidar_x + r * self._geometry.cos[seen]
        y = r * self._geometry.sin[seen]
        c, s = math.cos(skew), math.sin(skew)
        return c * x + s * y, -s * x + c * y, self.footprint.lidar_x * c

    def side_edge(self, side: float, reach: float, skew: float) -> float | None:
        """Where the solid on one side that the robot has passed ends, for a side without a fitted wall.

        Just out of a turn the followed side may show no wall to fit: only the end face of a thin
        wall across the robot's way (a hairpin round it, a one-cell dead end beyond it) and that
        wall's faces running away from the robot. ``side``: +1 left, -1 right; ``reach``: m from
        the LiDAR across the walls (wall_lost_distance); ``skew`` as in wall_end. The returns are
        turned into the walls' frame (x along them, rotation centre at 0, averaged on surfaces so
        that range noise does not push single returns ahead); of those on that side within
        ``reach`` across that are passing the LiDAR (no further ahead than WALL_END_SLACK, no
        further behind than EDGE_BEHIND), the furthest along gives the x returned: beyond it, up
        to the LiDAR, that side is open (the opening the robot turns into). A wall beyond the
        opening, ahead, does not count, nor one behind the robot (the far wall of the cell it
        turned in), which it never passed. None where nothing on that side is passing the LiDAR;
        the caller keeps what was seen (a face can drop out of a scan) and carries it back.
        """
        if self._smoothed is None or self._geometry is None:
            return None
        along, across, lidar = self._walls_frame(self._smoothed, skew)
        near = (side * across > 0.0) & (side * across <= reach)
        near &= (along <= lidar + WALL_END_SLACK) & (along > lidar - EDGE_BEHIND)
        return float(along[near].max()) if near.any() else None

    def free_travel(self, directions: np.ndarray, shrink: float = 0.0) -> np.ndarray:
        """For each direction (rad, robot frame), how far the disc can drive along it before touching a return.

        The same swept-band test as the straight-ahead clearance, turned to each direction:
        a return at p (rotation-centre frame) blocks direction u when |p x u| < R, after
        p . u - sqrt(R^2 - (p x u)^2) of travel. Without the side margin: a turn aims
        the robot, it does not drive blind; ``shrink`` (m) narrows the disc further, so
        that returns pushed inwards by range noise do not close a corridor the robot fits
        in. inf where nothing blocks; empty before any scan.
        """
        if self._smoothed is None or self._geometry is None:
            return np.full(len(directions), math.inf)
        seen = self._smoothed < np.inf
        r = self._smoothed[seen]
        x = self.footprint.lidar_x + r * self._geometry.cos[seen]
        y = r * self._geometry.sin[seen]
        ux, uy = np.cos(directions)[:, None], np.sin(directions)[:, None]
        along = x[None, :] * ux + y[None, :] * uy
        across = x[None, :] * uy - y[None, :] * ux
        reach = self.footprint.radius - shrink
        blocked = (np.abs(across) < reach) & (along > 0.0)
        travel = np.where(blocked, along - np.sqrt(np.maximum(reach * reach - across * across, 0.0)), np.inf)
        return np.maximum(travel.min(axis=1, initial=math.inf), 0.0)

    def _layout(self, count: int, angle_min: float, increment: float) -> _Geometry:
        key = (count, angle_min, increment)
        if key != self._key:
            self._geometry = _Geometry(count, angle_min, increment, self.sectors, self.footprint)
            self._key = key
        return self._geometry  # type: ignore[return-value]

    def _clearance(self, ranges: np.ndarray, geometry: _Geometry) -> tuple[float, int]:
        """How far the disc can drive straight on before it touches a return.

        A return at (x, y) in the robot frame lies in the swept band when |y| < R + m
        (m: the side margin) and ahead when x > 0; the widened disc's front reaches it
        after x - sqrt((R + m)^2 - y^2). A wall alongside, further than R + m, does not
        limit straight travel.
        """
        travel, side = scan_kernels.clearance(
            ranges,
            geometry.forward,
            geometry.forward_cos,
            geometry.forward_sin,
            geometry.band_limit,
            self.footprint.lidar_x,
            self.footprint.radius + self.footprint.side_margin,
        )
        return float(travel), int(side)


WALL_END_BAND = 0.08
"""m: returns this close to a passed wall's line belong to it (LiDAR noise up to 3 cm, end faces)."""
WALL_END_GAP = 0.1
"""m: a gap this long along the line ends the wall (an opening is at least a corridor wide)."""
WALL_END_SLACK = 0.03
"""m: the passed wall is the last run of returns on its line that ends before the LiDAR (plus this)."""
WALL_END_REACH = 0.8
"""m: returns further along the walls than this are not looked at."""
EDGE_BEHIND = 0.1
"""m: SectorReader.side_edge takes returns passing the LiDAR, at most this far behind it."""

CLEARANCE_MEAN_BEAMS = 5
"""The clearance reads ranges averaged over this many beams: range noise (sigma 3 cm) would
otherwise put some return of a wall alongside inside the band on every scan."""
MINIMUM_MEAN_ANGLE = math.radians(3.0)
"""The window minima read ranges averaged (_flat_mean) over the beams this close on either side
(5 beams of the 240-beam scan, 7 of the 360-beam LDS-01): at 3 cm noise the minimum of a front
window then lies about 2 cm short instead of 6; a flat wall reads exactly."""
MAX_MEAN_BEAMS = 61
"""The most beams one window-minimum average spans (+-3 deg of a 0.1 deg scan)."""
SMOOTH_SPREAD = 0.12
"""m: neighbouring ranges further apart than this are an edge, not noise on one surface."""

OUTLIER_JUMP = 0.05
"""m: a beam this far from the median of its neighbourhood is an outlier and takes that median."""


def _running_mean(ranges: np.ndarray, beams: int, wrap: bool) -> np.ndarray:
    """Each beam the mean of its ``beams`` neighbours (odd) where they lie on one smooth surface, else kept.

    One surface: all returned and within SMOOTH_SPREAD of each other. An edge (a thin wall's
    end against the room behind it) is never averaged away. At most scan_kernels.BLOCK beams.
    """
    _check_window(beams)
    return scan_kernels.running_mean(ranges, beams, wrap, SMOOTH_SPREAD)


FLAT_SPREAD = 0.2
"""m: neighbours further apart than this are an edge for the window minima's average. Wider than
SMOOTH_SPREAD: 7 beams at 3 cm noise spread over 12 cm in about one window in twenty, and each
such window kept a raw beam up to 10 cm short (a front read 0.26 m before a wall 0.36 m away);
6.7 sigma almost never. An edge is only blended where the depths differ by less."""
KEEP_SHARE = 1e-3
"""A range within this share of its neighbourhood's average is kept as measured (a centred circle
reads 0.05 % off the flat-wall average over +-3 deg; range noise of 1 cm at 3 m is 0.3 %)."""


def _flat_mean(ranges: np.ndarray, beams: int, increment: float, wrap: bool) -> np.ndarray:
    """Each beam's range averaged with its neighbours (``beams``, odd) where they lie on one smooth surface.

    Along a straight line 1/r is A cos(theta) + B sin(theta); over beams symmetric about theta
    its mean is 1/r(theta) times the mean cosine of their offsets, so that ratio returns a
    straight wall's range unchanged while averaging the noise. One surface: all returned and
    within FLAT_SPREAD of each other. A reading within KEEP_SHARE of that average agrees with its neighbours (noise-free
    data on any smooth surface) and is kept exactly. At most scan_kernels.BLOCK beams.
    """
    if beams <= 1:
        return ranges
    _check_window(beams)
    return scan_kernels.flat_mean(ranges, beams, wrap, FLAT_SPREAD, _mean_cosine(beams, increment), KEEP_SHARE)


@functools.lru_cache(maxsize=16)
def _mean_cosine(beams: int, increment: float) -> float:
    """The mean cosine of the beam offsets of a window of ``beams`` (odd) about its middle beam."""
    half = beams // 2
    return float(np.cos(increment * np.arange(-half, half + 1)).mean())


def _check_window(beams: int) -> None:
    if beams > scan_kernels.BLOCK:
        raise ValueError(f"a scan average spans at most {scan_kernels.BLOCK} beams, got {beams}")


def _running_median(ranges: np.ndarray, beams: int, wrap: bool) -> np.ndarray:
    """Beams further than OUTLIER_JUMP from the median of their neighbourhood (beams odd) take it.

    A lone spurious return, short or missing, never survives, while any object wider than
    beams // 2 + 1 beams stays; readings that agree with their neighbours are kept exactly.
    Wraps round a full-circle scan; a partial one repeats its end beams.
    """
    return scan_kernels.running_median(ranges, beams, wrap, OUTLIER_JUMP)


MIN_FIT_POINTS = 5
"""Fewer returns than this in a side window give no line."""


def _fit_line(r: np.ndarray, cos: np.ndarray, sin: np.ndarray) -> LineFit | None:
    """Principal axis of a window's returns (LiDAR frame): direction, distance and spread.

    Beams without a return are zeroed, so they add nothing to the sums.
    """
    if r.size > scan_kernels.BLOCK:
        finite = r < np.inf
        n = int(np.count_nonzero(finite))
        rz = np.where(finite, r, 0.0)
        x, y = rz * cos, rz * sin
        sx, sy = float(x.sum()), float(y.sum())
    else:  # the same values in one compiled pass
        n, x, y, sx, sy = scan_kernels.fit_points(r, cos, sin)
    if n < MIN_FIT_POINTS:
        return None
    mx, my = sx / n, sy / n
    sxx = float(x @ x) - sx * mx
    syy = float(y @ y) - sy * my
    sxy = float(x @ y) - sx * my
    angle = 0.5 * math.atan2(2.0 * sxy, sxx - syy)  # direction of largest spread
    # Smallest eigenvalue of the scatter matrix: the squared residuals across the line.
    across = 0.5 * (sxx + syy) - math.hypot(0.5 * (sxx - syy), sxy)
    distance = abs(-math.sin(angle) * mx + math.cos(angle) * my)
    along = 0.5 * (sxx + syy) + math.hypot(0.5 * (sxx - syy), sxy)
    rms = math.sqrt(max(across, 0.0) / n)
    return LineFit(distance, angle, rms, rms / math.sqrt(along) if along > 0.0 else math.inf)
