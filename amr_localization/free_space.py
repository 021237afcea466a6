"""Where a robot centre can be: known-free cells with some clearance from the walls.

Global localization draws its particles uniformly here, and the motion model
asks it whether a particle's move stayed here (a move into a wall, out of the
map or into unknown space is impossible for the real robot, so such particles
are killed rather than left inside walls).
"""

from __future__ import annotations

import math

import numpy as np

from amr_localization.distance_field import DistanceField
from amr_localization.errors import LocalizationError


class FreeSpace:
    """The cells of `field` at least `clearance` m from an occupied cell."""

    def __init__(self, field: DistanceField, clearance: float) -> None:
        if not math.isfinite(clearance) or clearance < 0.0:
            raise LocalizationError(f"free_space_clearance: must be a finite number >= 0 m, got {clearance!r}")
        self.grid = field.grid
        self.mask = field.free_mask(clearance)
        self._cells = np.flatnonzero(self.mask)
        if self._cells.size == 0:
            raise LocalizationError(
                f"map: no free cell {clearance} m or more from a wall "
                f"({self.grid.width}x{self.grid.height} cells of {self.grid.resolution} m): nowhere to localize"
            )

    @property
    def area(self) -> float:
        """m^2 of free space."""
        return self._cells.size * self.grid.resolution**2

    def sample(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """(count, 3) poses uniform over the free area, headings uniform in [-pi, pi)."""
        cells = self._cells[rng.integers(0, self._cells.size, count)]
        row, col = np.divmod(cells, self.grid.width)
        jitter = rng.random((count, 2))
        x0, y0, _ = self.grid.origin
        resolution = self.grid.resolution
        poses = np.empty((count, 3))
        poses[:, 0] = x0 + (col + jitter[:, 0]) * resolution
        poses[:, 1] = y0 + (row + jitter[:, 1]) * resolution
        poses[:, 2] = rng.uniform(-math.pi, math.pi, count)
        return poses

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """True where (x, y) lies in a free cell (False outside the map)."""
        row, col = self.grid.world_to_cell(x, y)
        inside = self.grid.inside(row, col)
        result = np.zeros(np.shape(x), dtype=bool)
        result[inside] = self.mask[row[inside], col[inside]]
        return result

    def segments_free(self, start: np.ndarray, end: np.ndarray) -> np.ndarray:
        """True where the straight move start[i] -> end[i] ((N, 2) arrays) stays in free space.

        Checked at points half a cell apart along each move, so a move cannot hop over a
        wall one cell thick.
        """
        length = np.hypot(*(end - start).T)
        samples = max(1, math.ceil(float(length.max(initial=0.0)) / (0.5 * self.grid.resolution)))
        free = np.ones(len(start), dtype=bool)
        for fraction in np.linspace(1.0, 0.0, samples, endpoint=False):
            point = start + fraction * (end - start)
            free &= self.contains(point[:, 0], point[:, 1])
        return free
