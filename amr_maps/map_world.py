"""An occupancy grid as a simulation world: occupied cells become solids.

A map saved by a real robot's SLAM becomes a maze to simulate. Runs of occupied cells are merged into
boxes (amr_maps.world.solid_cells) so physics and ray casting stay fast; unknown cells are left
open (nothing to collide with), which is what a simulated robot inside the walls never reaches.
A world file can also name a map (`map: lab.yaml` beside `start:`); this module is for grids in memory
and for bare map files, where a start pose may be missing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import ndimage

from amr_maps.map_io import load_map
from amr_maps.occupancy_grid import FREE, MapError, OccupancyGrid
from amr_maps.world import Goal, World, solid_cells
from amr_util.geometry import Pose2D, wrap_angle

OCCUPIED_PERCENT = 65
"""Cells at or above this value are solid: map_server's default occupied_thresh 0.65."""


def world_from_grid(
    grid: OccupancyGrid,
    start: tuple[float, float, float] | None = None,
    goal: Goal | None = None,
    name: str = "map",
    source: str = "<grid>",
    occupied_percent: int = OCCUPIED_PERCENT,
) -> World:
    """The world whose solids are the grid's occupied cells; start defaults to the most open free cell."""
    solid = grid.occupied(occupied_percent)
    if not solid.any():
        raise MapError(f"{source}: the map has no occupied cell (>= {occupied_percent}) to make walls of")
    boxes, faces = solid_cells(solid, grid.resolution, grid.origin[0], grid.origin[1])
    x, y, theta = start if start is not None else most_open_pose(grid, occupied_percent)
    return World(
        name=name, polygons=tuple(boxes), faces=faces, start=Pose2D(x, y, wrap_angle(theta)), goal=goal, source=source
    )


def load_map_world(path: str | Path, start: tuple[float, float, float] | None = None) -> World:
    """A map_server YAML file as a world (start: given, else the most open free cell)."""
    path = Path(path)
    return world_from_grid(load_map(path), start, name=path.stem, source=str(path))


def most_open_pose(grid: OccupancyGrid, occupied_percent: int = OCCUPIED_PERCENT) -> tuple[float, float, float]:
    """(x, y, 0) at the centre of the known-free cell farthest from any cell that is not free."""
    free = grid.free(FREE + 1) & ~grid.occupied(occupied_percent)
    if not free.any():
        raise MapError("the map has no free cell to start in")
    clearance = ndimage.distance_transform_edt(free)
    row, col = np.unravel_index(int(np.argmax(clearance)), clearance.shape)
    x, y = grid.cell_to_world(row, col)
    return float(x), float(y), 0.0
