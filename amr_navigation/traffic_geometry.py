"""The traffic rules' geometry, pure functions (no ROS, no state): the speed cap before an obstacle
(`obstacle_speed`), the scan's returns on the map and which are not on it (`scan_points`, `unmapped`), the path
ahead and the free travel along it (`path_ahead`, `free_travel`), and places to wait aside or back off to
(`place_aside`, `farthest_place`). amr_navigation.traffic applies them; docs/amr_navigation.md explains the rules.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from scipy.ndimage import distance_transform_edt, label

from amr_planning.costmap import Costmap
from amr_util.scan import ScanData


def obstacle_speed(free_travel: float, stop_distance: float, slow_distance: float, speed: float) -> float:
    """The speed cap for `free_travel` m of path before an obstacle: 0 at or below stop_distance, `speed` at
    or beyond slow_distance, linear between (infinite free travel: `speed`)."""
    if not free_travel > stop_distance:
        return 0.0
    if free_travel >= slow_distance:
        return speed
    return speed * (free_travel - stop_distance) / (slow_distance - stop_distance)


def scan_points(scan: ScanData, pose: tuple[float, float, float], lidar_x: float) -> tuple[np.ndarray, np.ndarray]:
    """(returns (N, 2) in the map frame, the same returns (N, 2) in the robot frame) of the valid beams
    (REP 117: NaN, inf and out-of-range dropped)."""
    ranges = np.asarray(scan.ranges, dtype=float)
    valid = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges <= scan.range_max)
    angles = scan.angle_min + scan.angle_increment * np.flatnonzero(valid)
    r = ranges[valid]
    local = np.stack([lidar_x + r * np.cos(angles), r * np.sin(angles)], axis=1)
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    world = np.stack([x + c * local[:, 0] - s * local[:, 1], y + s * local[:, 0] + c * local[:, 1]], axis=1)
    return world, local


def unmapped(costmap: Costmap, points: np.ndarray, tolerance: float) -> np.ndarray:
    """True for points (N, 2) farther than `tolerance` from every obstacle of the costmap's map (points off
    the map are taken as mapped: nothing is known there)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    row, col = costmap.grid.world_to_cell(points[:, 0], points[:, 1])
    inside = costmap.grid.inside(row, col)
    result = np.zeros(len(points), dtype=bool)
    result[inside] = costmap.clearance[row[inside], col[inside]] > tolerance
    return result


def path_ahead(path: np.ndarray, x: float, y: float, length: float, spacing: float = 0.025) -> np.ndarray:
    """The stretch of `path` (N, 2) from the point closest to (x, y) on, `length` m long, resampled every
    `spacing` m (its first point is that closest point)."""
    path = np.asarray(path, dtype=float)
    if len(path) == 1:
        return path.copy()
    starts, vectors = path[:-1], np.diff(path, axis=0)
    lengths = np.hypot(*vectors.T)
    rel = np.array([x, y]) - starts
    t = np.clip(
        np.divide((rel * vectors).sum(axis=1), lengths**2, out=np.zeros_like(lengths), where=lengths > 0), 0.0, 1.0
    )
    distances = np.hypot(*(starts + t[:, None] * vectors - (x, y)).T)
    best = int(np.argmin(distances))
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    begin = arc[best] + t[best] * lengths[best]
    end = min(arc[-1], begin + length)
    s = np.append(np.arange(begin, end, spacing), end)
    return np.stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])], axis=1)


def free_travel(stretch: np.ndarray, points: np.ndarray, reach: float, min_returns: int) -> float:
    """m along `stretch` (M, 2), a path resampled from the robot on, before its disc of radius `reach` touches
    `min_returns` of `points` (N, 2); inf when fewer are ever touched."""
    if len(points) < min_returns or len(stretch) == 0:
        return math.inf
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(stretch, axis=0).T))])
    distance = np.hypot(stretch[:, None, 0] - points[None, :, 0], stretch[:, None, 1] - points[None, :, 1])
    touched = distance <= reach
    hit = touched.any(axis=0)
    if np.count_nonzero(hit) < min_returns:
        return math.inf
    first = np.argmax(touched[:, hit], axis=0)  # the first sample touching each hit return
    return float(np.sort(arc[first])[min_returns - 1])


def min_distance(points: np.ndarray, x: float, y: float) -> float:
    """m from (x, y) to the nearest of points (N, 2); inf for none."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return float(np.hypot(points[:, 0] - x, points[:, 1] - y).min()) if len(points) else math.inf


def place_aside(
    costmap: Costmap, start: tuple[float, float], avoid: np.ndarray, distance: float, search: float
) -> tuple[float, float] | None:
    """The nearest cell (breadth-first, 8-connected, over the cells where the robot fits) at least `distance`
    from every point of `avoid` (N, 2) (others' paths and centres), within `search` m of steps; None if none.
    Cells clear of the safety margin are preferred (searched first); else any non-lethal cell."""
    avoid = np.asarray(avoid, dtype=float).reshape(-1, 2)
    # points farther than that from every cell the search can reach change nothing: left out (the cost is per point)
    avoid = avoid[
        np.abs(avoid - np.asarray(start, dtype=float)).max(axis=1) <= search + distance + 2.0 * costmap.grid.resolution
    ]
    for passable in (~costmap.inflated, ~costmap.lethal):
        found = _breadth_first(costmap, passable, start, avoid, distance, search)
        if found is not None:
            return found
    return None


def farthest_place(
    costmap: Costmap, start: tuple[float, float], avoid: np.ndarray
) -> tuple[tuple[float, float], float] | None:
    """The cell reachable from `start` (4-connected over the cells where the robot fits; those clear of the safety
    margin if the start has any such neighbour) farthest from every point of `avoid` (N, 2), and that distance (m);
    None if `avoid` is empty or the start is off the map. Where no place lies a given distance away (a dead end
    shorter than that), the way as far as it goes."""
    avoid = np.asarray(avoid, dtype=float).reshape(-1, 2)
    grid = costmap.grid
    row, col = (int(v) for v in grid.world_to_cell(start[0], start[1]))
    if len(avoid) == 0 or not grid.inside(row, col):
        return None
    seeds = np.zeros(costmap.shape, dtype=bool)
    rows, cols = grid.world_to_cell(avoid[:, 0], avoid[:, 1])
    inside = grid.inside(rows, cols)
    seeds[np.asarray(rows)[inside], np.asarray(cols)[inside]] = True
    if not seeds.any():
        return None
    away = distance_transform_edt(~seeds) * grid.resolution
    for passable in (~costmap.inflated, ~costmap.lethal):
        walk = passable.copy()
        walk[row, col] = True  # the robot stands where it stands, whatever the marks say
        parts, _ = label(walk)
        reach = parts == parts[row, col]
        if reach.sum() > 1:
            break
    score = np.where(reach, away, -1.0)
    best = np.unravel_index(int(np.argmax(score)), score.shape)
    x, y = costmap.centre(best[0], best[1])
    return (float(x), float(y)), float(score[best])


def _breadth_first(costmap, passable, start, avoid, distance, search):
    grid = costmap.grid
    row, col = (int(v) for v in grid.world_to_cell(start[0], start[1]))
    if not grid.inside(row, col):
        return None
    rows, cols = passable.shape
    # far enough from every avoided point: one distance transform-free test on all cells at once
    reach = int(math.ceil(search / grid.resolution))
    r0, r1 = max(0, row - reach), min(rows, row + reach + 1)
    c0, c1 = max(0, col - reach), min(cols, col + reach + 1)
    rr, cc = np.mgrid[r0:r1, c0:c1]
    centres = costmap.centre(rr, cc)
    clear = np.ones(rr.shape, dtype=bool)
    for chunk in np.array_split(avoid, max(1, len(avoid) // 64)) if len(avoid) else ():
        gap = np.hypot(centres[..., None, 0] - chunk[None, None, :, 0], centres[..., None, 1] - chunk[None, None, :, 1])
        clear &= (gap >= distance).all(axis=-1)
    ok = passable[r0:r1, c0:c1] & clear
    walk = passable[r0:r1, c0:c1]
    seen = np.zeros(walk.shape, dtype=bool)
    sr, sc = row - r0, col - c0
    queue = deque([(sr, sc)])
    seen[sr, sc] = True
    height, width = walk.shape
    while queue:
        i, j = queue.popleft()
        if ok[i, j]:
            x, y = costmap.centre(i + r0, j + c0)
            return float(x), float(y)
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)):
            a, b = i + di, j + dj
            if 0 <= a < height and 0 <= b < width and not seen[a, b] and walk[a, b]:
                seen[a, b] = True
                queue.append((a, b))
    return None
