"""The occupancy grid every map user in the suite shares (the data of nav_msgs/OccupancyGrid).

Conventions are those of nav_msgs/OccupancyGrid and map_server:
- `data[row, col]` with row 0 the bottom row (lowest y) and col 0 the leftmost column, so that
  `data.ravel()` is the message's row-major `data` starting at cell (0, 0);
- values 0 (free) .. 100 (occupied), -1 unknown;
- `origin` is the (x, y, yaw) pose, in the map frame, of cell (0, 0)'s lower-left corner. Only
  yaw = 0 is supported by the suite's users (map_server documents that most of ROS ignores it);
  a non-zero yaw is refused rather than silently ignored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FREE = 0
OCCUPIED = 100
UNKNOWN = -1


class MapError(ValueError):
    """A map that cannot be used, with a message naming what is wrong."""


@dataclass(frozen=True)
class OccupancyGrid:
    """A 2D occupancy grid: int8 cells, resolution in m/cell, origin of cell (0, 0)'s corner."""

    data: np.ndarray
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    frame_id: str = "map"

    def __post_init__(self) -> None:
        data = np.asarray(self.data)
        if data.ndim != 2 or data.size == 0:
            raise MapError(f"occupancy grid: data must be a non-empty 2D array, got shape {data.shape}")
        if not np.issubdtype(data.dtype, np.integer):
            raise MapError(f"occupancy grid: data must be integers, got {data.dtype}")
        if np.any((data < UNKNOWN) | (data > OCCUPIED)):
            raise MapError("occupancy grid: cell values must be -1 (unknown) or 0..100")
        resolution = float(self.resolution)
        if not np.isfinite(resolution) or resolution <= 0.0:
            raise MapError(f"occupancy grid: resolution must be a positive number of m/cell, got {self.resolution!r}")
        if len(self.origin) != 3 or not all(np.isfinite(v) for v in self.origin):
            raise MapError(f"occupancy grid: origin must be finite [x, y, yaw], got {self.origin!r}")
        if abs(float(self.origin[2])) > 1e-9:
            raise MapError(f"occupancy grid: origin yaw {self.origin[2]} is not supported (only 0)")
        data = np.ascontiguousarray(data, dtype=np.int8)
        data.setflags(write=False)
        object.__setattr__(self, "data", data)
        object.__setattr__(self, "resolution", resolution)
        object.__setattr__(self, "origin", tuple(float(v) for v in self.origin))

    @property
    def height(self) -> int:
        """Rows (cells along y)."""
        return int(self.data.shape[0])

    @property
    def width(self) -> int:
        """Columns (cells along x)."""
        return int(self.data.shape[1])

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the whole grid in the map frame."""
        x0, y0, _ = self.origin
        return x0, y0, x0 + self.width * self.resolution, y0 + self.height * self.resolution

    def occupied(self, threshold: int = 65) -> np.ndarray:
        """Boolean mask of cells at or above `threshold` (map_server's occupied_thresh in percent)."""
        return self.data >= threshold

    def free(self, threshold: int = 20) -> np.ndarray:
        """Boolean mask of known cells below `threshold` (map_server's free_thresh in percent)."""
        return (self.data >= 0) & (self.data < threshold)

    def world_to_cell(self, x, y):
        """(row, col) integer indices of the cells holding points (x, y); may lie outside the grid."""
        col = np.floor((np.asarray(x, dtype=float) - self.origin[0]) / self.resolution).astype(np.int64)
        row = np.floor((np.asarray(y, dtype=float) - self.origin[1]) / self.resolution).astype(np.int64)
        return row, col

    def cell_to_world(self, row, col):
        """(x, y) of the centres of cells (row, col)."""
        x = self.origin[0] + (np.asarray(col, dtype=float) + 0.5) * self.resolution
        y = self.origin[1] + (np.asarray(row, dtype=float) + 0.5) * self.resolution
        return x, y

    def inside(self, row, col):
        """True where (row, col) is a cell of the grid."""
        row = np.asarray(row)
        col = np.asarray(col)
        return (row >= 0) & (row < self.height) & (col >= 0) & (col < self.width)
