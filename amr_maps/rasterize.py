"""A world's solids as an occupancy grid in the world frame (`map`).

Rules (the ones map users may rely on):
- Occupied (100): a cell whose interior overlaps a solid with positive area ("any overlap", exact for
  convex polygons by the separating-axis test). A wall thinner than a cell still marks every cell it
  crosses, so 0.02 m walls survive at 0.05 m; a solid that only touches a cell's border does not
  mark it (overlaps under `tolerance`, 1e-6 of a cell, are float noise).
- Unknown (-1): free cells that connect (4-neighbourhood, through free cells) to the grid's border,
  i.e. outside the outer walls. If that region reaches the start pose the world is not closed, and
  then only the margin around the solids' bounding box is unknown.
- Free (0): every other cell.

The grid is aligned on the solids' lower-left bounding corner (minus the margin, a whole number of
cells), so a world whose coordinates lie on the resolution lattice rasterizes exactly: turned back into
a world (amr_maps.map_world) it has the same solids.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from amr_maps.occupancy_grid import FREE, OCCUPIED, UNKNOWN, MapError, OccupancyGrid
from amr_maps.world import World

DEFAULT_RESOLUTION = 0.05
DEFAULT_MARGIN = 0.1
RELATIVE_TOLERANCE = 1e-6
FOUR_NEIGHBOURS = ndimage.generate_binary_structure(2, 1)


def rasterize_world(
    world: World, resolution: float = DEFAULT_RESOLUTION, margin: float = DEFAULT_MARGIN, frame_id: str = "map"
) -> OccupancyGrid:
    """The occupancy grid of `world` at `resolution` m/cell with `margin` m (rounded up to cells) around."""
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0.0):
        raise MapError(f"rasterize: resolution must be a positive number of m/cell, got {resolution!r}")
    if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin >= 0.0):
        raise MapError(f"rasterize: margin must be a non-negative number of m, got {margin!r}")
    resolution = float(resolution)
    margin_cells = _cells(margin, resolution)
    xmin, ymin, xmax, ymax = world.bounds
    width = _cells(xmax - xmin, resolution) + 2 * margin_cells
    height = _cells(ymax - ymin, resolution) + 2 * margin_cells
    origin_x, origin_y = xmin - margin_cells * resolution, ymin - margin_cells * resolution

    occupied = np.zeros((height, width), dtype=bool)
    tolerance = RELATIVE_TOLERANCE * resolution
    for polygon in world.polygons:
        _mark_polygon(occupied, polygon, origin_x, origin_y, resolution, tolerance)

    data = np.where(occupied, OCCUPIED, FREE).astype(np.int8)
    outside = _outside(occupied)
    start_row = math.floor((world.start.y - origin_y) / resolution)
    start_col = math.floor((world.start.x - origin_x) / resolution)
    start_inside = 0 <= start_row < height and 0 <= start_col < width
    if not start_inside or outside[start_row, start_col]:  # not closed: only what lies beyond the solids is unknown
        outside = np.ones_like(occupied)
        outside[margin_cells : height - margin_cells, margin_cells : width - margin_cells] = False
        outside &= ~occupied
    data[outside] = UNKNOWN
    return OccupancyGrid(data, resolution, (origin_x, origin_y, 0.0), frame_id)


def _cells(length: float, resolution: float) -> int:
    """Whole cells covering `length` (a length within float noise of a multiple is that multiple)."""
    return max(0, math.ceil(length / resolution - RELATIVE_TOLERANCE))


def _mark_polygon(
    occupied: np.ndarray, polygon: np.ndarray, origin_x: float, origin_y: float, resolution: float, tolerance: float
) -> None:
    """Set the cells whose interior overlaps the convex counter-clockwise `polygon`.

    Separating axes of a box and a convex polygon: the box's x and y axes (the candidate window below)
    and each polygon edge's normal. For edge a->b with direction d, the polygon lies where
    cross(d, p - a) >= 0; the box overlaps that half plane by more than `tolerance` iff the largest
    cross(d, corner - a) / |d| over its corners exceeds it. cross(d, p - a) = d_x (p_y - a_y) - d_y (p_x - a_x)
    is separable in x and y, so its box maximum is a column term plus a row term.
    """
    height, width = occupied.shape
    col0 = max(0, math.floor((polygon[:, 0].min() + tolerance - origin_x) / resolution))
    col1 = min(width, math.ceil((polygon[:, 0].max() - tolerance - origin_x) / resolution))
    row0 = max(0, math.floor((polygon[:, 1].min() + tolerance - origin_y) / resolution))
    row1 = min(height, math.ceil((polygon[:, 1].max() - tolerance - origin_y) / resolution))
    if col0 >= col1 or row0 >= row1:
        return
    x_low = origin_x + np.arange(col0, col1) * resolution
    y_low = origin_y + np.arange(row0, row1) * resolution
    x_high, y_high = x_low + resolution, y_low + resolution
    inside = np.ones((row1 - row0, col1 - col0), dtype=bool)
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        dx, dy = b - a
        length = math.hypot(dx, dy)
        if length == 0.0:
            continue
        best_y = np.maximum(dx * (y_low - a[1]), dx * (y_high - a[1]))
        best_x = np.maximum(-dy * (x_low - a[0]), -dy * (x_high - a[0]))
        inside &= (best_y[:, None] + best_x[None, :]) > tolerance * length
    occupied[row0:row1, col0:col1] |= inside


def _outside(occupied: np.ndarray) -> np.ndarray:
    """Free cells connected to the grid's border through free cells (4-neighbourhood)."""
    labels, _ = ndimage.label(~occupied, structure=FOUR_NEIGHBOURS)
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    border = border[border != 0]
    return np.isin(labels, border)
