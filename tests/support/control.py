"""Synthetic LiDAR scans for the controller tests: exact ray casts against wall segments; a logger that keeps the
warnings a controller node says."""

from __future__ import annotations

import math

import numpy as np

from amr_util.scan import ScanData

BIG = 100.0


class WarningLog:
    """A node's logger in a test (`node.get_logger = lambda: log`): its warnings kept in `lines`, the rest dropped."""

    def __init__(self):
        self.lines: list[str] = []

    def warning(self, text, **_):
        self.lines.append(text)

    def __getattr__(self, level):
        return lambda text, **_: None


def cast(
    segments: list[tuple[float, float, float, float]],
    beams: int = 240,
    angle_min: float = 0.0,
    heading: float = 0.0,
    range_max: float = 3.5,
) -> ScanData:
    """A scan from a LiDAR at the origin facing `heading` (rad, world frame) among `segments`.

    Beam i points at angle_min + i * 2 pi / beams in the sensor frame; no return reads +inf.
    """
    increment = 2.0 * math.pi / beams
    angles = heading + angle_min + increment * np.arange(beams)
    dx, dy = np.cos(angles), np.sin(angles)
    best = np.full(beams, np.inf)
    for x1, y1, x2, y2 in segments:
        ex, ey = x2 - x1, y2 - y1
        denom = dx * ey - dy * ex
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (x1 * ey - y1 * ex) / denom  # distance along the beam
            u = (x1 * dy - y1 * dx) / denom  # position along the segment
        hit = (np.abs(denom) > 1e-12) & (t > 0.0) & (u >= 0.0) & (u <= 1.0)
        best = np.where(hit & (t < best), t, best)
    best[best > range_max] = np.inf
    return ScanData(best, angle_min, increment, 0.12, range_max)


def corridor(
    left: float = 0.2,
    right: float = 0.2,
    front: float | None = None,
    right_from: float = -BIG,
    left_from: float = -BIG,
    right_to: float = BIG,
    left_to: float = BIG,
) -> list[tuple[float, float, float, float]]:
    """Walls along x at y = +left and y = -right (spanning [from, to] in x), optionally a wall across at x = front."""
    walls = [(left_from, left, left_to, left), (right_from, -right, right_to, -right)]
    if front is not None:
        walls.append((front, -BIG, front, BIG))
    return walls
