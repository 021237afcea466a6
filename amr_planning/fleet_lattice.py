"""The lattice a fleet is planned on (the steps on it: amr_planning.fleet_paths), and where on it robots start.

- **Lattice** (`lattice`): `grid_lattice`, points `spacing` m apart, kept where the robot fits clear of the
  safety margin (outside the costmap's inflated cells); an edge joins two 4-neighbours whose segment stays
  outside the inflated cells. The grid is shifted by the offset (of `steps` x `steps` tried over one spacing)
  that keeps the most edges, and of those the one farthest from the walls (the clearance summed over the
  points): in a maze of cells `spacing` wide, the cell centres. A corridor at an angle to the grid (a rotated
  maze, bends, curves) leaves such a grid in pieces; where it does not follow the free space
  (`follows_free_space`) the lattice is `sampled_lattice` instead: points spread along the free space, joined
  where their geodesic Voronoi cells touch.
- **Start vertices** (`assign`): distinct vertices for points such as the robots where they stand, the
  assignment of least squared way lengths (a way goes straight to a vertex the point sees, then along the
  lattice).
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError, Reason


@dataclass(frozen=True)
class Lattice:
    """The graph robots are planned on: vertex k at `points[k]` (x, y), its neighbours `neighbours[k]`."""

    points: np.ndarray
    neighbours: tuple[tuple[int, ...], ...]
    spacing: float

    def __len__(self) -> int:
        return len(self.points)

    def nearest(self, x: float, y: float, taken=()) -> int:
        """The vertex nearest to (x, y), of those not in `taken`."""
        if not (math.isfinite(x) and math.isfinite(y)):
            raise PlanningError(Reason.INVALID, f"point ({x!r}, {y!r}) must be finite")
        gaps = np.hypot(self.points[:, 0] - x, self.points[:, 1] - y)
        gaps[list(taken)] = np.inf
        if not np.isfinite(gaps).any():
            raise PlanningError(Reason.INVALID, f"no vertex left near ({x:.3f}, {y:.3f}): all {len(self)} are taken")
        return int(np.argmin(gaps))

    def without(self, edges) -> Lattice:
        """This lattice without the edges (u, v) given (each both ways): an edge found blocked."""
        cut = {(int(u), int(v)) for u, v in edges} | {(int(v), int(u)) for u, v in edges}
        return Lattice(
            self.points,
            tuple(tuple(n for n in neighbours if (k, n) not in cut) for k, neighbours in enumerate(self.neighbours)),
            self.spacing,
        )

    def components(self) -> np.ndarray:
        """The connected component of each vertex (labels 0, 1, ...)."""
        component = np.full(len(self), -1, dtype=int)
        count = 0
        for first in range(len(self)):
            if component[first] >= 0:
                continue
            component[first], queue = count, deque([first])
            while queue:
                for other in self.neighbours[queue.popleft()]:
                    if component[other] < 0:
                        component[other] = count
                        queue.append(other)
            count += 1
        return component

    def distances(self, target: int) -> np.ndarray:
        """Steps from every vertex to `target` (breadth first; -1 where it cannot be reached)."""
        steps = np.full(len(self), -1, dtype=int)
        steps[target] = 0
        queue = deque([target])
        while queue:
            vertex = queue.popleft()
            for other in self.neighbours[vertex]:
                if steps[other] < 0:
                    steps[other] = steps[vertex] + 1
                    queue.append(other)
        return steps


def _clearance(costmap: Costmap, points: np.ndarray) -> np.ndarray:
    """m from each point (N, 2) to the nearest obstacle of the map."""
    rows, cols = costmap.grid.world_to_cell(points[:, 0], points[:, 1])
    return costmap.clearance[rows, cols] if len(points) else np.zeros(0)


def lattice(costmap: Costmap, spacing: float, steps: int = 16) -> Lattice:
    """The lattice of the free space `spacing` m apart (see the module docstring): the square grid
    (`grid_lattice`) where it follows the free space (`follows_free_space`), else points sampled over the free
    space (`sampled_lattice`)."""
    grid = grid_lattice(costmap, spacing, steps)
    return grid if follows_free_space(costmap, grid) else sampled_lattice(costmap, spacing)


def _check_spacing(costmap: Costmap, spacing: float) -> None:
    if not (math.isfinite(spacing) and spacing > costmap.resolution):
        raise PlanningError(
            Reason.INVALID,
            f"lattice spacing {spacing!r} must be finite and exceed the map's resolution ({costmap.resolution} m)",
        )


def grid_lattice(costmap: Costmap, spacing: float, steps: int = 16) -> Lattice:
    """The square grid of the free space `spacing` m apart, 4-neighbours joined (see the module docstring),
    shifted to the best of `steps` x `steps` offsets tried over one spacing."""
    _check_spacing(costmap, spacing)
    xmin, ymin, xmax, ymax = costmap.grid.bounds
    best = None
    for dx, dy in itertools.product(np.arange(steps) * spacing / steps, repeat=2):
        xs = np.arange(xmin + dx, xmax, spacing)
        ys = np.arange(ymin + dy, ymax, spacing)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        points = np.stack([gx.ravel(), gy.ravel()], axis=1)
        free = ~costmap.lethal_at(points, costmap.inflated)
        index = np.full(gx.shape, -1, dtype=int)
        index.ravel()[np.flatnonzero(free)] = np.arange(int(free.sum()))
        pairs = []
        for a, b in ((index[:-1, :], index[1:, :]), (index[:, :-1], index[:, 1:])):
            both = (a >= 0) & (b >= 0)
            pairs.append(np.stack([a[both], b[both]], axis=1))
        pairs = np.concatenate(pairs)
        kept = points[free]
        if len(pairs):
            pairs = pairs[costmap.segments_free(kept[pairs[:, 0]], kept[pairs[:, 1]], costmap.inflated)]
        score = (len(pairs), float(_clearance(costmap, kept).sum()))
        if best is None or score > best[0]:
            best = (score, kept, pairs)
    _, points, pairs = best
    neighbours: list[list[int]] = [[] for _ in range(len(points))]
    for a, b in pairs:
        neighbours[a].append(int(b))
        neighbours[b].append(int(a))
    return Lattice(points, tuple(tuple(sorted(n)) for n in neighbours), float(spacing))


COVER = 2.0
"""spacings: a grid lattice follows the free space only if every free cell of a region it reaches lies this close to
one of its points (a wider room's grid leaves at most about 1.7 spacings near walls and pillars)."""


def follows_free_space(costmap: Costmap, graph: Lattice, cover: float = COVER) -> bool:
    """Whether `graph` is a lattice robots can be planned on everywhere in the free space it reaches: in each
    region of the free space (cells outside the inflated band, `Costmap.regions`) that holds vertices, they are joined
    into one graph, and every free cell lies within `cover` spacings of one. A square grid follows the rooms and the
    grid mazes whose cells it fits; it does not follow a corridor at an angle to it (rotated, bent or curved ones),
    which it leaves in pieces or unvisited. A region without a vertex (a pocket no robot can leave) does not count."""
    from scipy.ndimage import distance_transform_edt

    if len(graph) == 0:
        return False
    regions = costmap.regions(costmap.inflated)
    rows, cols = costmap.grid.world_to_cell(graph.points[:, 0], graph.points[:, 1])
    held = regions[rows, cols]
    component = graph.components()
    for region in np.unique(held):
        if region == 0 or len(np.unique(component[held == region])) > 1:
            return False
    away = np.ones(regions.shape, dtype=bool)
    away[rows, cols] = False
    distance = distance_transform_edt(away) * costmap.resolution
    reached = np.isin(regions, np.unique(held))
    return bool(distance[reached].max() <= cover * graph.spacing)


def sampled_lattice(costmap: Costmap, spacing: float) -> Lattice:
    """A lattice of the free space for any layout (a corridor at any angle, bent or curved):

    - **Points**: the free cells (outside the inflated band; every cell an eighth of a spacing apart at most),
      taken farthest from the walls first, each kept unless a point already kept lies within `spacing` in sight
      of it (a point beyond a wall, in the next corridor, does not count). Corridors get points along their
      middle, and every free cell lies within about a spacing of a point it sees.
    - **Edges**: each free cell belongs to the point nearest to it along the free space (a geodesic Voronoi
      partition: multi-source Dijkstra over the free cells, 8-connected as the planner's A* moves); two points
      are joined where their cells touch. So the lattice is connected wherever the free space is, round corners
      and bends, and a robot driving from a point to a neighbour stays within their two cells, clear of a robot
      waiting at a third point."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    _check_spacing(costmap, spacing)
    stride = max(1, int(spacing / (8.0 * costmap.resolution)))
    candidates = np.zeros(costmap.inflated.shape, dtype=bool)
    candidates[::stride, ::stride] = ~costmap.inflated[::stride, ::stride]
    rows, cols = np.nonzero(candidates)
    if len(rows) == 0:
        return Lattice(np.zeros((0, 2)), (), float(spacing))
    order = np.lexsort((cols, rows, -costmap.clearance[rows, cols]))  # farthest from the walls first, then raster
    kept: list[np.ndarray] = []
    kept_cells: list[tuple[int, int]] = []
    buckets: dict[tuple[int, int], list[np.ndarray]] = {}
    limit = spacing * spacing - 1e-12
    for row, col in zip(rows[order], cols[order], strict=True):
        point = costmap.centre(row, col)
        key = (int(point[0] // spacing), int(point[1] // spacing))
        near = [
            other
            for dx in (-1, 0, 1)
            for dy in (-1, 0, 1)
            for other in buckets.get((key[0] + dx, key[1] + dy), ())
            if float((point - other) @ (point - other)) < limit
        ]
        if (
            near
            and costmap.segments_free(np.repeat(point[None], len(near), axis=0), np.array(near), costmap.lethal).any()
        ):
            continue
        kept.append(point)
        kept_cells.append((int(row), int(col)))
        buckets.setdefault(key, []).append(point)
    points = np.array(kept)
    # the geodesic Voronoi partition of the free cells among the points
    free = ~costmap.inflated
    index = np.full(free.shape, -1, dtype=int)
    index[free] = np.arange(int(free.sum()))
    heads, tails, weights = [], [], []
    height, width = free.shape
    for d_row, d_col in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = index[max(0, -d_row) : height - max(0, d_row), max(0, -d_col) : width - max(0, d_col)]
        b = index[max(0, d_row) : height - max(0, -d_row) or None, max(0, d_col) : width - max(0, -d_col) or None]
        both = (a >= 0) & (b >= 0)
        heads.append(a[both])
        tails.append(b[both])
        weights.append(np.full(int(both.sum()), math.hypot(d_row, d_col)))
    heads, tails, weights = np.concatenate(heads), np.concatenate(tails), np.concatenate(weights)
    count = int(free.sum())
    graph = coo_matrix((weights, (heads, tails)), shape=(count, count)).tocsr()
    sources = index[tuple(np.array(kept_cells).T)]
    _, _, owner_cell = dijkstra(graph, directed=False, indices=sources, min_only=True, return_predecessors=True)
    vertex_of = np.full(count, -1, dtype=int)
    vertex_of[sources] = np.arange(len(sources))
    owner = np.where(owner_cell >= 0, vertex_of[np.maximum(owner_cell, 0)], -1)
    a, b = owner[heads], owner[tails]
    touching = (a >= 0) & (b >= 0) & (a != b)
    pairs = np.unique(np.sort(np.stack([a[touching], b[touching]], axis=1), axis=1), axis=0)
    neighbours: list[list[int]] = [[] for _ in range(len(points))]
    for u, v in pairs:
        neighbours[u].append(int(v))
        neighbours[v].append(int(u))
    return Lattice(points, tuple(tuple(sorted(n)) for n in neighbours), float(spacing))


UNREACHABLE = 1e6
"""m, the way length standing for "no way" in `assign` (finite: the assignment solver needs finite costs)."""


def assign(graph: Lattice, costmap: Costmap, points, taken=(), reach: float = 1.5) -> list[int]:
    """Distinct vertices for the points (N, 2), e.g. the robots of a fleet where they stand: the assignment that
    least sums the squared lengths of the ways from each point to its vertex (scipy's linear_sum_assignment).

    The way from a point to a vertex v goes straight to a *home* vertex u, then along the lattice:
    |p - u| + spacing * steps(u, v). A point's homes are the vertices within `reach` spacings it sees (the segment
    outside the costmap's lethal cells), or the vertex nearest to it if it sees none (a point squeezed against a
    wall). Why not each point's nearest free vertex: two robots in one maze cell have one nearest vertex; the
    second nearest may lie beyond a wall, and the robot planned from there drives the long way round to it,
    against the plan. Squared lengths keep robots in a corridor in their order. `taken`: vertices no point may
    have. PlanningError when there are fewer vertices than points or a point is not finite."""
    from scipy.optimize import linear_sum_assignment

    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not np.isfinite(points).all():
        raise PlanningError(Reason.INVALID, f"points {points.tolist()} must be finite")
    free = np.setdiff1d(np.arange(len(graph)), np.asarray(list(taken), dtype=int))
    if len(points) > len(free):
        raise PlanningError(
            Reason.INVALID, f"no vertex left: {len(points)} points, {len(free)} of the {len(graph)} vertices free"
        )
    if len(points) == 0:
        return []
    cost = np.empty((len(points), len(free)))
    steps: dict[int, np.ndarray] = {}
    for row, point in enumerate(points):
        gaps = np.hypot(*(graph.points - point).T)
        near = np.flatnonzero(gaps <= reach * graph.spacing)
        homes = near[costmap.segments_free(np.repeat(point[None], len(near), axis=0), graph.points[near])]
        if len(homes) == 0:
            homes = np.array([int(np.argmin(gaps))])
        best = np.full(len(graph), np.inf)
        for home in homes:
            if home not in steps:
                steps[home] = graph.distances(int(home)).astype(float)
                steps[home][steps[home] < 0] = np.inf
            best = np.minimum(best, gaps[home] + graph.spacing * steps[home])
        cost[row] = np.minimum(best[free], UNREACHABLE)
    rows, columns = linear_sum_assignment(cost**2)
    chosen = np.empty(len(points), dtype=int)
    chosen[rows] = free[columns]
    return chosen.tolist()
