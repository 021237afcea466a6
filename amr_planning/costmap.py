"""A planning costmap from an occupancy grid: obstacles inflated by the robot, cost rising near walls.

For every cell the clearance c is the distance from its centre to the nearest obstacle, estimated
from the exact Euclidean distance transform (EDT) between cell centres minus half a cell (the
obstacle cell's own half width):

    c = res * EDT - res / 2

A cell is *lethal* when the robot's disc centred there would touch an obstacle, and *inflated*
when it would come closer than the safety margin:

    lethal:    c < robot_radius
    inflated:  c < r_inflated = robot_radius + safety_margin

Inflated cells that are not lethal can be crossed, at a steep extra cost (`margin_cost`), so that
a passage narrower than the margin wants but wide enough for the robot is used only when there is
no other way, through its middle. Elsewhere the cost of traversing a cell (per metre) is

    cost = 1 + w * max(0, 1 - (c - r_inflated) / d)^2

with w = ``cost_weight`` and d = ``cost_distance``: 1 in the open, 1 + w at the edge of the
inflated band, so that the cheapest route keeps to the middle of a corridor. The minimum cost is
1, which keeps A*'s distance heuristic admissible. The grid's border counts as an obstacle: the
robot never plans off the map. The clearance estimate is conservative (the wall may lie anywhere
in an occupied cell); maps of 0.35 m corridors need 0.025 m cells to leave the robot room.

`shared_costmap(grid, config)` is the costmap of one map and config built once per process (one costmap
per robot): every node of a composed process given the same /map and costmap parameters (each robot's planner, its
navigator's traffic rules, the fleet planner) holds the same read-only object instead of building its own.
"""

from __future__ import annotations

import hashlib
import math
import threading
import weakref
from dataclasses import dataclass, replace

import numba
import numpy as np
from scipy.ndimage import distance_transform_edt

from amr_maps.occupancy_grid import OccupancyGrid
from amr_planning.errors import PlanningError, Reason
from amr_util.parameter_spec import Config, parameter
from amr_util.robot_description import default_robot

MIN_COST = 1.0
"""The cost of a cell far from every wall: the factor that keeps the octile heuristic admissible."""


@dataclass(frozen=True)
class CostmapConfig(Config):
    robot_radius: float = parameter(default_robot().radius, minimum=0.01, maximum=2.0)
    """m, the disc footprint (default: the robot description's)."""
    safety_margin: float = parameter(0.02, minimum=0.0, maximum=1.0)
    """m kept between the footprint and any obstacle by every planned point."""
    cost_weight: float = parameter(3.0, minimum=0.0, maximum=1000.0)
    """extra cost at the edge of the inflated band (0: shortest paths, hugging the inflation)."""
    cost_distance: float = parameter(0.2, minimum=0.001, maximum=5.0)
    """m beyond the inflated band over which the extra cost falls to zero."""
    margin_cost: float = parameter(50.0, minimum=0.0, maximum=1e6)
    """extra cost of a cell inside the safety margin (where the robot fits, but barely)."""
    occupied_threshold: int = parameter(65, minimum=1, maximum=100)
    """cells at or above this occupancy (percent) are obstacles (map_server's occupied_thresh)."""
    unknown_is_obstacle: bool = parameter(True)
    """unknown cells (-1) are obstacles; false: they are free."""

    @property
    def inflation_radius(self) -> float:
        return self.robot_radius + self.safety_margin


class Costmap:
    """Clearance, lethal mask and traversal cost of every cell of an OccupancyGrid."""

    def __init__(self, grid: OccupancyGrid, config: CostmapConfig | None = None) -> None:
        self.grid = grid
        self.config = config or CostmapConfig()
        resolution = grid.resolution
        obstacle = grid.occupied(self.config.occupied_threshold)
        if self.config.unknown_is_obstacle:
            obstacle = obstacle | (grid.data < 0)
        self.obstacle = obstacle
        # Pad with an obstacle ring so that the map border counts as a wall.
        padded = np.pad(~obstacle, 1, constant_values=False)
        edt = distance_transform_edt(padded)[1:-1, 1:-1]
        self.clearance = np.where(obstacle, 0.0, edt * resolution - 0.5 * resolution)
        self.lethal = obstacle | (self.clearance < self.config.robot_radius)
        self.inflated = self.lethal | (self.clearance < self.config.inflation_radius)
        excess = (self.clearance - self.config.inflation_radius) / self.config.cost_distance
        rise = np.clip(1.0 - excess, 0.0, 1.0) ** 2
        cost = MIN_COST + self.config.cost_weight * rise + np.where(self.inflated, self.config.margin_cost, 0.0)
        self.cost = np.where(self.lethal, np.inf, cost)
        self._nearest_free: np.ndarray | None = None

    @property
    def resolution(self) -> float:
        return self.grid.resolution

    def with_obstacles(self, points, radius: float) -> Costmap:
        """A new costmap, same config, of a copy of this map with discs of `radius` (m) around `points`
        (N, 2) marked occupied: obstacles seen but not on the map (another robot), inflated as walls are.
        Points off the map mark nothing; this costmap and its grid are unchanged."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        points = points[np.isfinite(points).all(axis=1)]
        if len(points) == 0 or not (math.isfinite(radius) and radius >= 0.0):
            return Costmap(self.grid, self.config)
        data = np.array(self.grid.data)
        resolution = self.grid.resolution
        reach = int(math.ceil(radius / resolution)) + 1
        offsets = np.arange(-reach, reach + 1)
        d_row, d_col = np.meshgrid(offsets, offsets, indexing="ij")
        rows, cols = self.grid.world_to_cell(points[:, 0], points[:, 1])
        rows = (np.asarray(rows)[:, None, None] + d_row).ravel()
        cols = (np.asarray(cols)[:, None, None] + d_col).ravel()
        centres = self.centre(rows, cols)
        near = np.hypot(*(np.repeat(points, d_row.size, axis=0) - centres).T) <= radius + 0.5 * resolution
        inside = self.grid.inside(rows, cols) & near
        data[rows[inside], cols[inside]] = 100
        return Costmap(replace(self.grid, data=data), self.config)

    def regions(self, mask: np.ndarray | None = None) -> np.ndarray:
        """The regions of the cells outside the lethal cells (or outside `mask`, e.g. `inflated`), 8-connected as
        A* moves: labels 1, 2, ..., 0 in the cells left out."""
        from scipy.ndimage import label

        blocked = self.lethal if mask is None else mask
        regions, _ = label(~blocked, structure=np.ones((3, 3), dtype=bool))
        return regions

    @property
    def shape(self) -> tuple[int, int]:
        return self.lethal.shape  # type: ignore[return-value]

    def cell(self, x: float, y: float, what: str = "point") -> tuple[int, int]:
        """(row, col) of a point on the map; PlanningError naming `what` if it is not finite or off the map."""
        if not (_is_real(x) and _is_real(y)) or not (math.isfinite(x) and math.isfinite(y)):
            raise PlanningError(Reason.INVALID, f"{what} ({x!r}, {y!r}) must be finite numbers", _endpoint(what))
        row, col = self.grid.world_to_cell(x, y)
        if not self.grid.inside(row, col):
            xmin, ymin, xmax, ymax = self.grid.bounds
            raise PlanningError(
                Reason.OUTSIDE_MAP,
                f"{what} ({x:.3f}, {y:.3f}) is off the map [{xmin:.2f}, {xmax:.2f}] x [{ymin:.2f}, {ymax:.2f}]",
                _endpoint(what),
            )
        return int(row), int(col)

    def centre(self, row, col) -> np.ndarray:
        """(x, y) of cell centres, as an (..., 2) array."""
        x, y = self.grid.cell_to_world(row, col)
        return np.stack([x, y], axis=-1)

    def lethal_at(self, points: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """True for points (N, 2) in a lethal cell (or a cell of `mask`, e.g. `inflated`) or off the map."""
        mask = self.lethal if mask is None else mask
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        row, col = self.grid.world_to_cell(points[:, 0], points[:, 1])
        inside = self.grid.inside(row, col)
        result = np.ones(len(points), dtype=bool)
        result[inside] = mask[row[inside], col[inside]]
        return result

    def segments_free(self, starts: np.ndarray, ends: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """True for each segment starts[i] -> ends[i] whose every point lies outside the lethal cells
        (or the cells of `mask`) and on the map.

        Each segment is sampled every quarter cell (a lethal cell is never stepped over: the
        inflation band is wider than a cell wherever it matters): n = max(ceil(length / (res / 4)), 1) + 1
        points start + k / (n - 1) (end - start), k = 0 .. n - 1, each in the cell `lethal_at` reads. A segment
        with a non-finite end is not free. One compiled pass that stops at a segment's first blocked point.
        """
        starts = _read_only(np.asarray(starts, dtype=float).reshape(-1, 2))
        ends = _read_only(np.asarray(ends, dtype=float).reshape(-1, 2))
        if len(starts) != len(ends):
            raise ValueError(f"segments_free: {len(starts)} starts but {len(ends)} ends")
        origin_x, origin_y = float(self.grid.origin[0]), float(self.grid.origin[1])
        mask = _read_only(np.asarray(self.lethal if mask is None else mask, dtype=bool))
        return _segments_free(starts, ends, 0.25 * self.resolution, mask, origin_x, origin_y, float(self.resolution))

    def nearest_free(self, row: int, col: int) -> tuple[int, int]:
        """The non-lethal cell nearest to (row, col) (itself if it is free); (-1, -1) if none exists."""
        if self._nearest_free is None:
            if self.lethal.all():
                self._nearest_free = np.full((2,) + self.lethal.shape, -1)
            else:
                _, self._nearest_free = distance_transform_edt(self.lethal, return_indices=True)
        return int(self._nearest_free[0, row, col]), int(self._nearest_free[1, row, col])


def _read_only(array: np.ndarray) -> np.ndarray:
    """A C-contiguous read-only view (a copy only where not contiguous): one compiled variant of a kernel whatever
    the caller's array (numba compiles read-only and writable arrays apart; a shared costmap's are read-only)."""
    view = np.ascontiguousarray(array).view()
    view.flags.writeable = False
    return view


@numba.njit(cache=True, error_model="numpy")
def _segments_free(starts, ends, step, mask, origin_x, origin_y, resolution):  # pragma: no cover - compiled
    """Costmap.segments_free's samples, a segment at a time, each left at its first point in `mask` or off it."""
    height, width = mask.shape
    free = np.zeros(starts.shape[0], dtype=np.bool_)
    for i in range(starts.shape[0]):
        start_x, start_y = starts[i, 0], starts[i, 1]
        dx, dy = ends[i, 0] - start_x, ends[i, 1] - start_y
        if not (np.isfinite(start_x) and np.isfinite(start_y) and np.isfinite(dx) and np.isfinite(dy)):
            continue
        samples = max(math.ceil(np.hypot(dx, dy) / step), 1) + 1
        free[i] = True
        for k in range(samples):
            fraction = k / (samples - 1)
            col = math.floor((start_x + fraction * dx - origin_x) / resolution)
            row = math.floor((start_y + fraction * dy - origin_y) / resolution)
            if row < 0 or row >= height or col < 0 or col >= width or mask[row, col]:
                free[i] = False
                break
    return free


_SHARED: weakref.WeakValueDictionary[tuple, Costmap] = weakref.WeakValueDictionary()
_SHARED_LOCK = threading.Lock()


def shared_costmap(grid: OccupancyGrid, config: CostmapConfig | None = None) -> Costmap:
    """The costmap of `grid` with `config`, built once per process: a later call with an equal map (the same cells,
    resolution, origin and frame) and an equal config gets the same object while anyone holds it. Its arrays are
    read-only (one holder cannot change another's map); `with_obstacles` gives a marked copy as ever."""
    config = config or CostmapConfig()
    data = np.ascontiguousarray(grid.data)
    key = (
        data.shape,
        grid.resolution,
        tuple(grid.origin),
        grid.frame_id,
        hashlib.blake2b(data.tobytes(), digest_size=16).digest(),
        config,
    )
    with _SHARED_LOCK:  # two executor threads given the same map build it once
        costmap = _SHARED.get(key)
        if costmap is None:
            costmap = Costmap(grid, config)
            for array in (costmap.obstacle, costmap.clearance, costmap.lethal, costmap.inflated, costmap.cost):
                array.setflags(write=False)
            _SHARED[key] = costmap
        return costmap


def _is_real(value) -> bool:
    return isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)


def _endpoint(what: str) -> str:
    """The PlanningError endpoint of a checked point: "start", "goal", or "" for any other point."""
    return what if what in ("start", "goal") else ""
