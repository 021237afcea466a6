"""A robot's view of a true grid without a simulator: what a 360-beam LiDAR at a pose would reveal."""

from __future__ import annotations

import numpy as np

from amr_maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid


def unknown_like(truth: OccupancyGrid) -> np.ndarray:
    return np.full(truth.data.shape, UNKNOWN, dtype=np.int8)


def reveal(
    truth: OccupancyGrid, known: np.ndarray, x: float, y: float, max_range: float = 3.5, beams: int = 360
) -> None:
    """Mark in `known` the cells beams from (x, y) cross (free) and stop at (occupied), up to max_range."""
    step = 0.5 * truth.resolution
    angles = np.linspace(0.0, 2.0 * np.pi, beams, endpoint=False)
    distances = np.arange(0.0, max_range, step)
    px = x + np.cos(angles)[:, None] * distances
    py = y + np.sin(angles)[:, None] * distances
    rows, cols = truth.world_to_cell(px, py)
    inside = truth.inside(rows, cols)
    rows, cols = np.where(inside, rows, 0), np.where(inside, cols, 0)
    blocked = ~inside | (truth.data[rows, cols] >= 65) | (truth.data[rows, cols] == UNKNOWN)
    first = np.where(blocked.any(axis=1), blocked.argmax(axis=1), len(distances))
    for beam in range(beams):
        end = first[beam]
        known[rows[beam, :end], cols[beam, :end]] = truth.data[rows[beam, :end], cols[beam, :end]]
        if end < len(distances) and inside[beam, end] and truth.data[rows[beam, end], cols[beam, end]] >= 65:
            known[rows[beam, end], cols[beam, end]] = OCCUPIED
