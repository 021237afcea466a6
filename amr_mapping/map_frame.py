"""A SLAM map in the world's frame (no ROS).

GraphSlam's map frame is where the robot started: the first scan's pose is (0, 0, 0). The simulator, a world's
goal and its ground truth are in the world's frame, where the robot started at the world's start pose
(x, y, theta). So world = start (+) slam (amr_util.geometry.compose), and the saved map's cells are put in the
world's frame by that transform: with theta 0 only the yaml origin moves by (x, y); otherwise the grid is
resampled (nearest cell: each world cell takes the SLAM cell its centre falls in), since map_server's origin
yaw must be 0. `maze_navigation map:=` then localizes and plans on it as on the world's own map.
"""

from __future__ import annotations

import math

import numpy as np

from amr_mapping.errors import MappingError
from amr_maps.occupancy_grid import UNKNOWN, OccupancyGrid
from amr_util.geometry import compose, wrap_angle

ANGLE_TOLERANCE = 1e-9
"""rad: a start heading this close to 0 only shifts the origin (no resampling)."""


def map_in_world(grid: OccupancyGrid, start) -> OccupancyGrid:
    """The SLAM grid (map frame: the robot's first pose) in the world frame, the robot having started at
    `start` (x, y, theta) of the world. Same resolution; cells outside the SLAM grid are unknown."""
    start = np.asarray(start, dtype=float).reshape(-1)
    if start.shape != (3,) or not np.all(np.isfinite(start)):
        raise MappingError(f"map_in_world: start must be a finite (x, y, theta), got {start!r}")
    theta = wrap_angle(float(start[2]))
    res = grid.resolution
    ox, oy = grid.origin[0], grid.origin[1]
    if abs(theta) <= ANGLE_TOLERANCE:
        return OccupancyGrid(grid.data.copy(), res, (ox + start[0], oy + start[1], 0.0), grid.frame_id)
    rows, cols = grid.data.shape
    corners = np.array([[ox, oy], [ox + cols * res, oy], [ox, oy + rows * res], [ox + cols * res, oy + rows * res]])
    world = np.array([compose(start, (x, y, 0.0))[:2] for x, y in corners])
    low = np.floor(np.round(world.min(axis=0) / res, 6)) * res  # rounded: a quarter turn keeps the cell count
    high = np.ceil(np.round(world.max(axis=0) / res, 6)) * res
    width, height = (int(round(v)) for v in (high - low) / res)
    # each world cell's centre, back in the SLAM frame: inverse(start) (+) w
    wy, wx = np.mgrid[0:height, 0:width]
    cx, cy = low[0] + (wx + 0.5) * res - start[0], low[1] + (wy + 0.5) * res - start[1]
    c, s = math.cos(theta), math.sin(theta)
    sx, sy = c * cx + s * cy, -s * cx + c * cy
    col = np.floor((sx - ox) / res).astype(np.int64)
    row = np.floor((sy - oy) / res).astype(np.int64)
    inside = (col >= 0) & (col < cols) & (row >= 0) & (row < rows)
    data = np.full((height, width), UNKNOWN, dtype=np.int8)
    data[inside] = grid.data[row[inside], col[inside]]
    return OccupancyGrid(data, res, (float(low[0]), float(low[1]), 0.0), grid.frame_id)


__all__ = ["map_in_world"]
