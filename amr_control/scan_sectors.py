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

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np


@dataclass(frozen=True)
class ScanData:
    """The fields of a sensor_msgs/LaserScan that the controller reads."""

    ranges: Sequence[float] | np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float = 0.0
    range_max: float = math.inf


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


@dataclass(frozen=True)
class Footprint:
    """A disc robot and where its LiDAR sits (m, robot frame, x ahead)."""

    radius: float
    lidar_x: float = 0.0
    lidar_y: float = 0.0


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


class _Geometry:
    """Per-beam index sets and unit vectors for one (count, angle_min, increment) layout."""

    def __init__(self, count: int, angle_min: float, increment: float, sectors: Sectors) -> None:
        angles = angle_min + increment * np.arange(count)
        wrapped = np.arctan2(np.sin(angles), np.cos(angles))
        self.cos = np.cos(wrapped)
        self.sin = np.sin(wrapped)

        def window(center: float, half: float) -> np.ndarray:
            offset = np.arctan2(np.sin(wrapped - center), np.cos(wrapped - center))
            return np.flatnonzero(np.abs(offset) <= half + 1e-9)

        self.front = window(0.0, sectors.front_half_width)
        self.ahead = window(0.0, sectors.abeam_half_width)
        self.left = window(sectors.left_center, sectors.side_half_width)
        self.right = window(sectors.right_center, sectors.side_half_width)
        self.left_abeam = window(sectors.left_center, sectors.abeam_half_width)
        self.right_abeam = window(sectors.right_center, sectors.abeam_half_width)


class SectorReader:
    """Turns scans into :class:`Readings`; caches the beam layout between scans."""

    def __init__(self, sectors: Sectors, footprint: Footprint) -> None:
        self.sectors = sectors
        self.footprint = footprint
        self._key: tuple[Any, ...] | None = None
        self._geometry: _Geometry | None = None

    def geometry_ok(self, scan: ScanData) -> str | None:
        """None if the scan's layout is usable, else what is wrong with it."""
        count = len(scan.ranges)
        if count == 0:
            return "empty scan"
        if not (math.isfinite(scan.angle_min) and math.isfinite(scan.angle_increment)):
            return f"non-finite angle_min {scan.angle_min} or angle_increment {scan.angle_increment}"
        if scan.angle_increment == 0.0 and count > 1:
            return "angle_increment is 0"
        return None

    def read(self, scan: ScanData) -> Readings:
        """Sector minima and straight-ahead clearance; assumes geometry_ok(scan) is None."""
        raw = np.asarray(scan.ranges, dtype=float)
        geometry = self._layout(len(raw), scan.angle_min, scan.angle_increment)
        range_min = scan.range_min if math.isfinite(scan.range_min) and scan.range_min > 0.0 else 0.0
        range_max = scan.range_max if scan.range_max > range_min else math.inf  # NaN compares False
        with np.errstate(invalid="ignore"):
            measured = (raw >= range_min) & (raw <= range_max)
        too_close = raw == -np.inf
        # Ignored readings become +inf: they never lower a minimum.
        ranges = np.where(measured, raw, np.inf)
        ranges[too_close] = range_min
        usable = int(np.count_nonzero(measured | too_close | (raw == np.inf)))

        front = _window_min(ranges, geometry.front)
        ahead = _window_min(ranges, geometry.ahead)
        left = _window_min(ranges, geometry.left)
        right = _window_min(ranges, geometry.right)
        left_abeam = _window_min(ranges, geometry.left_abeam)
        right_abeam = _window_min(ranges, geometry.right_abeam)
        left_fit = _fit_line(ranges, geometry, geometry.left)
        right_fit = _fit_line(ranges, geometry, geometry.right)
        clearance, side = self._clearance(ranges, geometry)
        sizes = (geometry.front.size, geometry.left_abeam.size, geometry.right_abeam.size)
        return Readings(
            front, ahead, left, right, left_abeam, right_abeam, left_fit, right_fit, clearance, side, usable, sizes
        )

    def _layout(self, count: int, angle_min: float, increment: float) -> _Geometry:
        key = (count, angle_min, increment)
        if key != self._key:
            self._geometry = _Geometry(count, angle_min, increment, self.sectors)
            self._key = key
        return self._geometry  # type: ignore[return-value]

    def _clearance(self, ranges: np.ndarray, geometry: _Geometry) -> tuple[float, int]:
        """How far the disc can drive straight on before it touches a return.

        A return at (x, y) in the robot frame lies in the swept band when |y| < R
        and ahead when x > 0; the disc's front reaches it after x - sqrt(R^2 - y^2).
        A wall alongside, however close, does not limit straight travel.
        """
        finite = np.isfinite(ranges)
        if not finite.any():
            return math.inf, 0
        r = ranges[finite]
        x = self.footprint.lidar_x + r * geometry.cos[finite]
        y = self.footprint.lidar_y + r * geometry.sin[finite]
        radius = self.footprint.radius
        in_band = (np.abs(y) < radius) & (x > 0.0)
        if not in_band.any():
            return math.inf, 0
        travel = x[in_band] - np.sqrt(radius * radius - y[in_band] ** 2)
        nearest = int(np.argmin(travel))
        return float(max(travel[nearest], 0.0)), (1 if y[in_band][nearest] > 0.0 else -1)


def _window_min(ranges: np.ndarray, indices: np.ndarray) -> float:
    return float(ranges[indices].min()) if indices.size else math.inf


MIN_FIT_POINTS = 5
"""Fewer returns than this in a side window give no line."""


def _fit_line(ranges: np.ndarray, geometry: _Geometry, indices: np.ndarray) -> LineFit | None:
    """Principal axis of the window's returns (LiDAR frame): direction, distance and spread."""
    r = ranges[indices]
    finite = np.isfinite(r)
    if np.count_nonzero(finite) < MIN_FIT_POINTS:
        return None
    r = r[finite]
    x = r * geometry.cos[indices][finite]
    y = r * geometry.sin[indices][finite]
    mx, my = x.mean(), y.mean()
    dx, dy = x - mx, y - my
    sxx, syy, sxy = float(dx @ dx), float(dy @ dy), float(dx @ dy)
    angle = 0.5 * math.atan2(2.0 * sxy, sxx - syy)  # direction of largest spread
    # Smallest eigenvalue of the scatter matrix: the squared residuals across the line.
    across = 0.5 * (sxx + syy) - math.hypot(0.5 * (sxx - syy), sxy)
    distance = abs(-math.sin(angle) * mx + math.cos(angle) * my)
    return LineFit(distance, angle, math.sqrt(max(across, 0.0) / r.size))
