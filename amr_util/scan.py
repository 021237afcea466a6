"""The scan type every scan reader shares: the fields of a sensor_msgs/LaserScan, without ROS.

The wall follower, the path follower and the localizers read scans as ScanData; a node converts a
LaserScan with amr_util.messages.scan_data, a library loop reads a simulator with scan_of (the lockstep harness,
amr_util.harness, does).
Readings follow sensor_msgs/LaserScan and REP 117 (+inf: no return, -inf: closer than range_min).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ScanData:
    """The fields of a sensor_msgs/LaserScan that the scan readers use."""

    ranges: Sequence[float] | np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float = 0.0
    range_max: float = math.inf


def scan_of(sim) -> ScanData:
    """The current scan of a simulator (anything with ``ranges`` and a ``lidar`` holding angle_min,
    angle_increment, range_min and range_max, as amr_simulation's Simulator), copied: the library loops
    that drive one without ROS (closed loops, benchmarks) read it this way."""
    return scan_from(sim.ranges, sim.lidar)


def scan_from(ranges, lidar) -> ScanData:
    """`ranges` copied, with the beam geometry of `lidar` (angle_min, angle_increment, range_min, range_max)."""
    return ScanData(np.array(ranges), lidar.angle_min, lidar.angle_increment, lidar.range_min, lidar.range_max)
