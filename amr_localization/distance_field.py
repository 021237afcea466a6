"""Distance from every cell of a map to the nearest occupied cell, computed once per map.

Both the likelihood field (how far a beam end point lies from a wall) and the
free-space mask (where a robot centre may be) read it. The exact Euclidean
distance transform (scipy.ndimage.distance_transform_edt, linear in the cell
count) measures between cell centres, so values are multiples of nothing in
particular and exact to the grid: 0 on occupied cells.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt

from amr_localization.errors import LocalizationError
from amr_maps.occupancy_grid import OccupancyGrid


class DistanceField:
    """distances[row, col] (m) to the nearest occupied cell, +inf on a map without any."""

    def __init__(self, grid: OccupancyGrid, occupied_threshold: int = 65, free_threshold: int = 20) -> None:
        if not isinstance(grid, OccupancyGrid):
            raise LocalizationError(f"map: expected an amr_maps OccupancyGrid, got {type(grid).__name__}")
        self.grid = grid
        occupied = grid.occupied(occupied_threshold)
        self.free = grid.free(free_threshold)
        if occupied.any():
            self.distances = distance_transform_edt(~occupied) * grid.resolution
        else:
            self.distances = np.full(occupied.shape, np.inf)
        self.distances.setflags(write=False)

    def free_mask(self, clearance: float) -> np.ndarray:
        """Known-free cells at least `clearance` m from every occupied cell: where a robot centre may be."""
        return self.free & (self.distances >= clearance)
