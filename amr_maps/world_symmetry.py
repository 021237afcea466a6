"""Whether a world maps onto itself under a half or quarter turn: a robot cannot tell its pose from its rotated image
there, so a particle filter must never say localized in it (twin_rooms), and a fleet world must break the symmetry
(fleets/crossing.yaml's box on the north wall)."""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import distance_transform_edt

from amr_maps.rasterize import rasterize_world
from amr_maps.world import World


def rotationally_symmetric(world: World, resolution: float = 0.02, tolerance: float = 0.05) -> str:
    """'' or the rotation ('90 deg', '180 deg') that maps the walls onto themselves: a robot cannot tell
    its pose from its rotated image there, so a particle filter must never say localized (twin_rooms)."""
    grid = rasterize_world(world, resolution)
    occupied = grid.occupied()
    rows, cols = np.nonzero(occupied)
    points = np.stack(grid.cell_to_world(rows, cols), axis=1)
    centre = points.mean(axis=0)
    distance = distance_transform_edt(~occupied) * resolution
    for degrees in (180, 90):
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
        turned = (points - centre) @ np.array([[c, s], [-s, c]]) + centre
        row, col = grid.world_to_cell(turned[:, 0], turned[:, 1])
        inside = (row >= 0) & (row < grid.height) & (col >= 0) & (col < grid.width)
        if inside.mean() > 0.99 and np.mean(distance[row[inside], col[inside]] <= tolerance) > 0.99:
            return f"{degrees} deg"
    return ""
