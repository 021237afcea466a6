"""Grids built with numpy for the planning tests (no rasterizer needed)."""

from __future__ import annotations

import numpy as np

from amr_maps.occupancy_grid import OccupancyGrid


def walled(rows: int, cols: int, resolution: float = 0.05, origin=(0.0, 0.0)) -> np.ndarray:
    """A free rows x cols area closed by a one-cell wall (int8 occupancy data)."""
    data = np.zeros((rows, cols), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return data


def grid(data: np.ndarray, resolution: float = 0.05, origin=(0.0, 0.0)) -> OccupancyGrid:
    return OccupancyGrid(data, resolution, (origin[0], origin[1], 0.0))


def random_blocks(rng: np.random.Generator, rows: int, cols: int, count: int, largest: int = 6) -> np.ndarray:
    """A walled area with `count` random rectangular blocks."""
    data = walled(rows, cols)
    for _ in range(count):
        r, c = rng.integers(0, rows), rng.integers(0, cols)
        h, w = rng.integers(1, largest, 2)
        data[r : r + h, c : c + w] = 100
    return data
