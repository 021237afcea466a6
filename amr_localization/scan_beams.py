"""The beams of a LaserScan a measurement model uses: valid returns, at most max_beams, evenly spread.

REP 117: +inf is "no return within range", -inf "closer than range_min", NaN an
invalid reading. None of them places an end point on a wall, so none is used by
the likelihood field (AMCL skips max-range readings the same way); the beam
model, which predicts ranges, gives +inf its max-range term (see beam_model.py).
Finite readings outside [range_min, range_max] (an LDS writes 0.0 for a failed
beam) are invalid too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from amr_localization.errors import LocalizationError
from amr_util.scan import ScanData


@dataclass(frozen=True)
class Beams:
    """Selected beams: ranges (m), angles in the sensor frame (rad), and whether each is a return."""

    ranges: np.ndarray
    angles: np.ndarray
    returned: np.ndarray
    range_max: float
    steps: np.ndarray
    """Each beam's index in the scan minus the first selected one's (angles[0] + steps * angle_increment)."""
    angle_increment: float


def checked_ranges(scan: ScanData) -> np.ndarray:
    """The scan's ranges as floats, after checking the scan's geometry; raises naming the bad field."""
    try:
        ranges = np.asarray(scan.ranges, dtype=float)
    except (TypeError, ValueError) as error:
        raise LocalizationError(f"scan: ranges are not numbers ({error})") from error
    if ranges.ndim != 1 or ranges.size == 0:
        raise LocalizationError(f"scan: ranges must be a non-empty list, got shape {ranges.shape}")
    for name in ("angle_min", "angle_increment", "range_min", "range_max"):
        value = getattr(scan, name)
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            raise LocalizationError(f"scan: {name} must be a finite number, got {value!r}")
    if scan.angle_increment == 0.0 and ranges.size > 1:
        raise LocalizationError("scan: angle_increment is 0 with more than one beam")
    if not 0.0 <= scan.range_min < scan.range_max:
        raise LocalizationError(f"scan: needs 0 <= range_min < range_max, got {scan.range_min}, {scan.range_max}")
    return ranges


def select_beams(scan: ScanData, max_beams: int, keep_no_return: bool = False) -> Beams:
    """Up to max_beams usable beams, evenly spread over the usable ones (all of them if fewer).

    keep_no_return: also select +inf readings (as range_max, returned=False) for models
    that score a missing return.
    """
    ranges = checked_ranges(scan)
    returned = (ranges >= scan.range_min) & (ranges <= scan.range_max)  # False for NaN and +-inf
    usable = returned | (keep_no_return & (ranges == np.inf))
    index = np.flatnonzero(usable)
    if index.size > max_beams:
        index = index[np.linspace(0, index.size - 1, max_beams).round().astype(np.intp)]
    return Beams(
        ranges=np.where(returned[index], ranges[index], scan.range_max),
        angles=scan.angle_min + index * scan.angle_increment,
        returned=returned[index],
        range_max=float(scan.range_max),
        steps=index - index[0] if index.size else index,
        angle_increment=float(scan.angle_increment),
    )
