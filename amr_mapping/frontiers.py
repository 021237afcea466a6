"""Frontiers on an occupancy grid, how far the robot has to drive to each, and which one to explore next.
Plain numpy and scipy, no ROS (amr_mapping.explorer keeps the state between maps; explorer_node is the ROS shell).

Frontier cells are known free cells (occupancy >= 0 and below `free_threshold`, 50 %) with an unknown (-1) cell among
their 4 neighbours; they are grouped 8-connected into frontiers, and frontiers shorter than `min_frontier_size`
(cells x resolution, m) are dropped (gaps between beams, not openings).

Reachability. The robot drives over *safe* cells: free cells whose clearance to any cell that is not free (a
wall, an uncertain or an unknown cell; the grid's border too) is at least `robot_radius` (clearance = EDT x
resolution - resolution / 2, as amr_planning.costmap estimates it). Unknown cells within `footprint_radius` of
the robot count as free (it stands there, though a LiDAR's range_min leaves them unseen). Distances are
shortest 8-connected paths over the safe cells from the robot (scipy.sparse.csgraph.dijkstra; the robot's cell
is taken to the nearest safe cell within `approach_distance`). A frontier cell is in reach when a path over
free cells (round a wall, never through it) at most `approach_distance` long joins it to a reachable safe
cell; a frontier is reachable when one of its cells is. Its goal is the reachable safe cell nearest (by that
path) to its cell in reach nearest its centroid, and its distance the path length from the robot to the goal.

Choice, explore_lite's rule (`frontier_search.cpp`, frontierCost):

    cost = potential_scale * distance - gain_scale * length          (length = size x resolution, m)

the lowest cost wins: near and long frontiers first. What is given up rules frontiers out (blacklisted):
  - a point (a goal the navigator could not plan to or reach): every frontier whose goal lies within
    `blacklist_radius` of it;
  - a frontier from a goal (the goal was reached and the frontier stayed: what lies beyond cannot be seen from
    there): a frontier whose goal lies within `blacklist_radius` of that goal and at least half of whose cells lie
    within a cell of that frontier's cells (SAME_FRONTIER_SHARE). A frontier grown mostly of new cells is another
    one (an opening seen only as the robot arrived), and the same frontier with its goal elsewhere (the map grew:
    another view of it) is tried there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.ndimage import distance_transform_edt, label
from scipy.sparse.csgraph import dijkstra

from amr_maps.occupancy_grid import UNKNOWN, OccupancyGrid
from amr_util.parameter_spec import Config, parameter
from amr_util.robot_description import default_robot

EIGHT = np.ones((3, 3), dtype=bool)
SAME_FRONTIER_SHARE = 0.5
"""a frontier is a given-up one when at least this share of its cells lie within a cell (8-neighbours) of its cells."""
STEPS = ((0, 1, 1.0), (1, 0, 1.0), (1, 1, math.sqrt(2.0)), (1, -1, math.sqrt(2.0)))
"""(d_row, d_col, length in cells) of the 8-connected moves, each pair of cells once (edges are undirected)."""


@dataclass(frozen=True)
class FrontierConfig(Config):
    """How frontiers are found, reached and weighed (explore_lite's names where it has the knob)."""

    potential_scale: float = parameter(3.0, minimum=0.0, maximum=1e6, live=True)
    """weight of the distance to a frontier (per m of path; explore_lite potential_scale)."""
    gain_scale: float = parameter(1.0, minimum=0.0, maximum=1e6, live=True)
    """weight of a frontier's length (per m; explore_lite gain_scale)."""
    min_frontier_size: float = parameter(0.2, minimum=0.0, maximum=100.0, live=True)
    """m, shorter frontiers are ignored (explore_lite min_frontier_size; 0.75 there, too long for 0.35 m corridors)."""
    robot_radius: float = parameter(default_robot().radius, minimum=0.01, maximum=2.0, live=True)
    """m, the disc footprint: safe cells keep at least this much from anything not free (default: the robot
    description's footprint)."""
    approach_distance: float = parameter(0.3, minimum=0.0, maximum=5.0, live=True)
    """m, a frontier is reachable when a reachable safe cell lies this close to one of its cells (the planner's
    snap_distance); also how far the robot's cell may be from the nearest safe one."""
    footprint_radius: float = parameter(0.2, minimum=0.0, maximum=2.0, live=True)
    """m, unknown cells this close to the robot are taken as free (it stands there; the LiDAR's range_min, 0.12 m
    from a mount 0.032 m behind the centre, leaves them unseen)."""
    blacklist_radius: float = parameter(0.3, minimum=0.0, maximum=10.0, live=True)
    """m, a frontier whose goal lies this close to a blacklisted point is not chosen."""
    free_threshold: int = parameter(50, minimum=1, maximum=100, live=True)
    """occupancy (percent) below which a known cell is free: seen free more than occupied (one free observation
    of amr_maps.scan_mapping's log-odds grid makes 40; the planner's obstacles start at 65)."""


@dataclass(frozen=True)
class Frontier:
    """One frontier: its cells, its middle, and how the robot gets there (goal, path length; inf if it cannot)."""

    cells: np.ndarray
    """(K, 2) (row, col) of its cells."""
    centroid: tuple[float, float]
    """m, the mean of its cells' centres."""
    length: float
    """m, cells x resolution."""
    goal: tuple[float, float] | None = None
    """m, the reachable safe cell the robot is sent to; None when it cannot reach the frontier."""
    distance: float = math.inf
    """m of 8-connected path from the robot to the goal."""
    cost: float = math.inf
    """potential_scale * distance - gain_scale * length (inf when unreachable or blacklisted)."""
    blacklisted: bool = False

    @property
    def size(self) -> int:
        return int(len(self.cells))

    @property
    def reachable(self) -> bool:
        return self.goal is not None


def frontier_mask(grid: OccupancyGrid, free_threshold: int = 50) -> np.ndarray:
    """Free cells with an unknown 4-neighbour."""
    data = grid.data
    free = (data >= 0) & (data < free_threshold)
    unknown = np.pad(data == UNKNOWN, 1, constant_values=False)
    beside = unknown[:-2, 1:-1] | unknown[2:, 1:-1] | unknown[1:-1, :-2] | unknown[1:-1, 2:]
    return free & beside


def detect_frontiers(grid: OccupancyGrid, min_frontier_size: float = 0.2, free_threshold: int = 50) -> list[Frontier]:
    """The frontiers of `grid` (8-connected groups of frontier cells at least min_frontier_size m long), largest first;
    not yet reached (goal None)."""
    labels, count = label(frontier_mask(grid, free_threshold), structure=EIGHT)
    if count == 0:
        return []
    rows, cols = np.nonzero(labels)
    order = np.argsort(labels[rows, cols], kind="stable")
    rows, cols = rows[order], cols[order]
    splits = np.cumsum(np.bincount(labels[rows, cols], minlength=count + 1)[1:])[:-1]
    frontiers = []
    for r, c in zip(np.split(rows, splits), np.split(cols, splits), strict=True):
        length = len(r) * grid.resolution
        if length + 1e-9 < min_frontier_size:
            continue
        x, y = grid.cell_to_world(r, c)
        frontiers.append(Frontier(np.column_stack([r, c]), (float(x.mean()), float(y.mean())), length))
    return sorted(frontiers, key=lambda f: -f.size)


def with_robot_free(grid: OccupancyGrid, robot: tuple[float, float], radius: float) -> OccupancyGrid:
    """`grid` with its unknown cells within `radius` m of `robot` (x, y) made free: the robot stands there, though a
    LiDAR's range_min leaves them unseen (else they would be a frontier around the robot and no cell near it safe)."""
    reach = int(math.ceil(radius / grid.resolution)) + 1
    row, col = (int(v) for v in grid.world_to_cell(robot[0], robot[1]))
    r0, r1 = max(row - reach, 0), min(row + reach + 1, grid.height)
    c0, c1 = max(col - reach, 0), min(col + reach + 1, grid.width)
    if r0 >= r1 or c0 >= c1:
        return grid
    rows, cols = np.mgrid[r0:r1, c0:c1]
    x, y = grid.cell_to_world(rows, cols)
    data = np.array(grid.data)
    patch = data[r0:r1, c0:c1]
    patch[(np.hypot(x - robot[0], y - robot[1]) <= radius) & (patch == UNKNOWN)] = 0
    return OccupancyGrid(data, grid.resolution, grid.origin, grid.frame_id)


def safe_cells(grid: OccupancyGrid, robot_radius: float, free_threshold: int = 50) -> np.ndarray:
    """Free cells where the robot's disc fits among free cells (the grid's border counts as not free)."""
    data = grid.data
    free = (data >= 0) & (data < free_threshold)
    res = grid.resolution
    clearance = distance_transform_edt(np.pad(free, 1, constant_values=False))[1:-1, 1:-1] * res - 0.5 * res
    return free & (clearance >= robot_radius)


def grid_graph(mask: np.ndarray, resolution: float, corners: np.ndarray | None = None) -> sp.csr_matrix:
    """The 8-connected graph of the cells of `mask` (node = row * width + col), edges weighted by their length in m.
    A diagonal step joins two cells only when both cells it squeezes between are in `corners` (default: `mask`):
    the planner's grid A* never cuts a corner (amr_planning.astar), so a chain of cells touching only at their
    corners is no way for it (a frontier reached so was planned to in vain, NO_PATH, and blacklisted: perfect mazes
    were done at 8 s)."""
    corners = mask if corners is None else corners
    height, width = mask.shape
    index = np.arange(mask.size).reshape(mask.shape)
    heads, tails, weights = [], [], []
    for d_row, d_col, length in STEPS:  # d_row >= 0: cell (r, c) and cell (r + d_row, c + d_col)
        first = slice(0, height - d_row), slice(max(0, -d_col), width - max(0, d_col))
        second = slice(d_row, height), slice(max(0, d_col), width - max(0, -d_col))
        both = mask[first] & mask[second]
        if d_row and d_col:  # the corners: (r + d_row, c) and (r, c + d_col)
            beside_row = slice(d_row, height), slice(max(0, -d_col), width - max(0, d_col))
            beside_col = slice(0, height - d_row), slice(max(0, d_col), width - max(0, -d_col))
            both &= corners[beside_row] & corners[beside_col]
        heads.append(index[first][both])
        tails.append(index[second][both])
        weights.append(np.full(int(both.sum()), length * resolution))
    return sp.csr_matrix(
        (np.concatenate(weights), (np.concatenate(heads), np.concatenate(tails))), shape=(mask.size, mask.size)
    )


def path_distances(safe: np.ndarray, start: tuple[int, int], resolution: float) -> np.ndarray:
    """m of the shortest 8-connected path over `safe` from cell `start` to every cell (inf: not reachable)."""
    index = int(np.ravel_multi_index(start, safe.shape))
    return dijkstra(grid_graph(safe, resolution), directed=False, indices=index).reshape(safe.shape)


def approaches(
    free: np.ndarray, reachable: np.ndarray, resolution: float, limit: float
) -> tuple[np.ndarray, np.ndarray]:
    """For every cell: (m of the shortest 8-connected path over free cells from the nearest reachable cell, inf beyond
    `limit`; that reachable cell's flat index, -1 if none). Paths go round walls, never through them; a diagonal
    step may pass between two cells touching at their corners (a sight line to the frontier, not a way to drive;
    refusing it too chose goals the frontier could not be seen from: inner_maze was left 97.6 % seen)."""
    sources = np.flatnonzero(reachable)
    if len(sources) == 0:
        return np.full(free.shape, np.inf), np.full(free.shape, -1)
    mask = free | reachable
    gaps, _, nearest = dijkstra(
        grid_graph(mask, resolution, corners=np.ones_like(mask)),
        directed=False,
        indices=sources,
        min_only=True,
        limit=limit + 1e-9,
        return_predecessors=True,
    )
    return gaps.reshape(free.shape), nearest.reshape(free.shape)


def same_frontier(grid: OccupancyGrid, frontier: Frontier, points) -> bool:
    """Whether at least SAME_FRONTIER_SHARE of `frontier`'s cells lie within a cell (8-neighbours) of the cells of
    `points` ((K, 2) x, y: frontier_points of a frontier given up)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) == 0 or frontier.size == 0:
        return False
    rows, cols = (np.asarray(v, dtype=int) for v in grid.world_to_cell(points[:, 0], points[:, 1]))
    near = (np.abs(frontier.cells[:, None, 0] - rows[None, :]) <= 1) & (
        np.abs(frontier.cells[:, None, 1] - cols[None, :]) <= 1
    )
    return bool(near.any(axis=1).mean() >= SAME_FRONTIER_SHARE)


def frontier_points(grid: OccupancyGrid, frontier: Frontier) -> np.ndarray:
    """(K, 2) x, y of a frontier's cells: what a frontier given up is remembered by (the grid may grow)."""
    x, y = grid.cell_to_world(frontier.cells[:, 0], frontier.cells[:, 1])
    return np.column_stack([np.asarray(x, dtype=float), np.asarray(y, dtype=float)])


def reach_frontiers(
    grid: OccupancyGrid,
    frontiers: list[Frontier],
    robot: tuple[float, float],
    config: FrontierConfig,
    blacklist=(),
    given_up=(),
) -> list[Frontier]:
    """Each frontier with its goal, distance and cost from the robot at `robot` (x, y); blacklisted ones marked:
    a goal within blacklist_radius of a point of `blacklist`, or of the goal of a (goal, frontier_points) pair of
    `given_up` whose frontier it is (same_frontier; module docstring)."""
    if not frontiers:
        return []
    safe = safe_cells(grid, config.robot_radius, config.free_threshold)
    res = grid.resolution
    start = _start_cell(grid, safe, robot, config.approach_distance)
    if start is None:
        return [
            Frontier(f.cells, f.centroid, f.length, blacklisted=_near(f.centroid, blacklist, config)) for f in frontiers
        ]
    distances = path_distances(safe, start, res)
    free = (grid.data >= 0) & (grid.data < config.free_threshold)
    gaps, nearest = approaches(free, np.isfinite(distances), res, config.approach_distance)
    result = []
    for frontier in frontiers:
        rows, cols = frontier.cells[:, 0], frontier.cells[:, 1]
        close = np.isfinite(gaps[rows, cols])
        if not close.any():
            result.append(
                Frontier(
                    frontier.cells,
                    frontier.centroid,
                    frontier.length,
                    blacklisted=_near(frontier.centroid, blacklist, config),
                )
            )
            continue
        x, y = grid.cell_to_world(rows, cols)
        to_middle = np.hypot(x - frontier.centroid[0], y - frontier.centroid[1])
        pick = int(np.argmin(np.where(close, to_middle, np.inf)))
        goal_cell = tuple(int(v) for v in np.unravel_index(nearest[rows[pick], cols[pick]], grid.data.shape))
        gx, gy = grid.cell_to_world(*goal_cell)
        goal = (float(gx), float(gy))
        distance = float(distances[goal_cell])
        banned = _near(goal, blacklist, config) or any(
            _near(goal, [point], config) and same_frontier(grid, frontier, cells) for point, cells in given_up
        )
        cost = math.inf if banned else config.potential_scale * distance - config.gain_scale * frontier.length
        result.append(Frontier(frontier.cells, frontier.centroid, frontier.length, goal, distance, cost, banned))
    return result


def best_frontier(frontiers: list[Frontier]) -> int:
    """Index of the reachable, not blacklisted frontier of least cost; -1 if there is none (exploration is done)."""
    costs = [f.cost if f.reachable and not f.blacklisted else math.inf for f in frontiers]
    if not costs or not math.isfinite(min(costs)):
        return -1
    return int(np.argmin(costs))


def _start_cell(grid: OccupancyGrid, safe: np.ndarray, robot, approach: float) -> tuple[int, int] | None:
    """The robot's cell, or the nearest safe cell within `approach` m of it; None if there is none."""
    row, col = (int(v) for v in grid.world_to_cell(robot[0], robot[1]))
    if not grid.inside(row, col) or not safe.any():
        return None
    if safe[row, col]:
        return row, col
    rows, cols = np.nonzero(safe)
    gap = np.hypot(rows - row, cols - col) * grid.resolution
    nearest = int(np.argmin(gap))
    return (int(rows[nearest]), int(cols[nearest])) if gap[nearest] <= approach else None


def _near(point, blacklist, config: FrontierConfig) -> bool:
    return any(math.hypot(point[0] - bx, point[1] - by) <= config.blacklist_radius for bx, by in blacklist)
