"""Range-to-beacon measurements with a compass (the ULL robot's sense(): d_1..d_n plus a heading).

    expected d_i(x, y) = || (x, y) - b_i ||
    mismatch(pose)     = sum_i | d_i(pose) - z_i | + | wrap_angle(theta - z_theta) |          (seed 000, chapter 4)
    log p(z | pose)    = sum_i log N(z_i; d_i, sigma_range) + log N(wrap_angle(theta - z_theta); 0, sigma_compass)

Beacon i is the i-th row of `positions`; BeaconRanges messages keep that order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_localization.errors import BeaconError
from amr_util.geometry import wrap_angle


def checked_beacons(positions) -> np.ndarray:
    """(B, 2) finite beacon positions; raises on an empty or malformed list."""
    array = np.asarray(positions, dtype=float) if len(positions) else np.zeros((0, 2))
    if array.ndim != 2 or array.shape[1] != 2:
        raise BeaconError(f"beacons: expected a list of [x, y], got shape {array.shape}")
    if array.shape[0] == 0:
        raise BeaconError("beacons: the list is empty: nothing to measure ranges to")
    if not np.isfinite(array).all():
        raise BeaconError("beacons: positions must be finite")
    return array


def same_beacons(expected: np.ndarray, positions, tolerance: float = 1e-6) -> None:
    """Raises, naming the difference, unless `positions` are the `expected` beacons in the same order (each
    within `tolerance` m): a reading measured to other beacons cannot be scored against these."""
    array = np.asarray(positions, dtype=float).reshape(-1, 2) if len(positions) else np.zeros((0, 2))
    if array.shape != expected.shape:
        raise BeaconError(f"beacons: {array.shape[0]} beacon positions, expected {expected.shape[0]}")
    if not np.isfinite(array).all():
        raise BeaconError("beacons: positions must be finite")
    moved = np.flatnonzero(np.hypot(*(array - expected).T) > tolerance)
    if moved.size:
        i = int(moved[0])
        raise BeaconError(
            f"beacons: beacon {i} at ({array[i, 0]:.3f}, {array[i, 1]:.3f}), expected "
            f"({expected[i, 0]:.3f}, {expected[i, 1]:.3f}) (positions changed)"
        )


@dataclass(frozen=True)
class BeaconReading:
    """Measured ranges (one per beacon, in the beacons' order) and compass heading (rad)."""

    ranges: np.ndarray
    compass: float

    @classmethod
    def checked(cls, ranges, compass: float, beacon_count: int) -> BeaconReading:
        values = np.asarray(ranges, dtype=float)
        if values.shape != (beacon_count,):
            raise BeaconError(f"beacon ranges: expected {beacon_count} values (one per beacon), got {values.size}")
        bad = np.flatnonzero(~np.isfinite(values) | (values < 0.0))
        if bad.size:
            raise BeaconError(
                f"beacon ranges: range {bad[0]} is {values[bad[0]]}: every range must be a finite number >= 0"
            )
        if not math.isfinite(compass):
            raise BeaconError(f"beacon ranges: compass heading must be finite, got {compass}")
        return cls(values, float(compass))


def expected_ranges(xy: np.ndarray, beacons: np.ndarray) -> np.ndarray:
    """(N, B) distances from (N, 2) positions to the beacons."""
    return np.hypot(xy[:, None, 0] - beacons[None, :, 0], xy[:, None, 1] - beacons[None, :, 1])


def range_mismatch(xy: np.ndarray, beacons: np.ndarray, reading: BeaconReading) -> np.ndarray:
    """(N,) sum_i |d_i - z_i| (m) for candidate positions."""
    return np.abs(expected_ranges(xy, beacons) - reading.ranges[None, :]).sum(axis=1)


def beacon_log_likelihood(
    particles: np.ndarray, beacons: np.ndarray, reading: BeaconReading, sigma_range: float, sigma_compass: float
) -> np.ndarray:
    """(N,) log p(ranges, compass | pose), Gaussian in each range and in the heading error."""
    range_error = expected_ranges(particles[:, :2], beacons) - reading.ranges[None, :]
    heading_error = wrap_angle(particles[:, 2] - reading.compass)
    return -0.5 * ((range_error / sigma_range) ** 2).sum(axis=1) - 0.5 * (heading_error / sigma_compass) ** 2
