"""A* on the costmap's grid, 8-connected.

Moving from cell a to a neighbour b costs the step length times the mean of their costs:

    g(b) = g(a) + |ab| * (cost(a) + cost(b)) / 2,   |ab| = res or res * sqrt(2)

and the heuristic is the octile distance to the goal scaled by the minimum cell cost (1),

    h(n) = res * (max(dr, dc) + (sqrt(2) - 1) * min(dr, dc)) * MIN_COST

which never exceeds the true remaining cost (every step costs at least its length), so the path
found is optimal. A diagonal step is taken only when both cells it squeezes between are not lethal,
so a path never cuts the corner of an obstacle. Lethal cells are impassable; cells inside the safety
margin cost so much more (Costmap) that they are crossed only where there is no other way.

Speed: the search runs on flat Python lists over a grid padded with one blocked cell, so a
neighbour needs no bounds check, and the heuristic of every cell is computed once with numpy.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass

import numpy as np

from amr_planning.costmap import MIN_COST, Costmap
from amr_planning.endpoints import assemble, resolve
from amr_planning.errors import PlanningError, Reason

SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class GridPath:
    """A planned path and what the search cost."""

    points: np.ndarray
    """(N, 2) x, y in the map frame, from the start to the goal."""
    cost: float
    """the path's cost (cost-weighted metres) over the searched cells."""
    expanded: int
    """cells taken off the open list."""
    seconds: float
    """wall-clock time of the search."""

    @property
    def length(self) -> float:
        return float(np.hypot(*np.diff(self.points, axis=0).T).sum())


class GridAStar:
    """A* over one costmap; build once, plan many times."""

    def __init__(self, costmap: Costmap, snap_distance: float = 0.3) -> None:
        self.costmap = costmap
        self.snap_distance = snap_distance
        rows, cols = costmap.shape
        self._width = cols + 2
        padded = np.pad(costmap.cost, 1, constant_values=np.inf)
        self._cost = padded.ravel().tolist()
        w = self._width
        half = 0.5 * costmap.resolution
        diagonal = half * SQRT2
        # (offset, half step length, the two orthogonal cells a diagonal squeezes between or 0)
        self._moves = (
            (1, half, 0, 0),
            (-1, half, 0, 0),
            (w, half, 0, 0),
            (-w, half, 0, 0),
            (w + 1, diagonal, w, 1),
            (w - 1, diagonal, w, -1),
            (-w + 1, diagonal, -w, 1),
            (-w - 1, diagonal, -w, -1),
        )

    def plan(self, start, goal) -> GridPath:
        """The cheapest path from start (x, y) to goal (x, y); PlanningError if there is none."""
        began = time.perf_counter()
        start_end = resolve(self.costmap, start, "start", self.snap_distance)
        goal_end = resolve(self.costmap, goal, "goal", self.snap_distance)
        cells, cost, expanded = self._search(start_end.cell, goal_end.cell)
        if cells is None:
            raise PlanningError(
                Reason.UNREACHABLE,
                f"no collision-free path from ({start_end.point[0]:.3f}, {start_end.point[1]:.3f}) to "
                f"({goal_end.point[0]:.3f}, {goal_end.point[1]:.3f}) for a robot of radius "
                f"{self.costmap.config.robot_radius:.3f} m ({expanded} cells searched)",
            )
        points = assemble(self.costmap, start_end, goal_end, cells)
        return GridPath(points, cost, expanded, time.perf_counter() - began)

    def _heuristic(self, goal_row: int, goal_col: int) -> list[float]:
        rows, cols = self.costmap.shape
        dr = np.abs(np.arange(-1, rows + 1) - goal_row)[:, None]
        dc = np.abs(np.arange(-1, cols + 1) - goal_col)[None, :]
        octile = np.maximum(dr, dc) + (SQRT2 - 1.0) * np.minimum(dr, dc)
        return (octile * (self.costmap.resolution * MIN_COST)).ravel().tolist()

    def _search(self, start: tuple[int, int], goal: tuple[int, int]):
        """(cells (N, 2) of row, col, cost, expanded) or (None, inf, expanded)."""
        w = self._width
        source = (start[0] + 1) * w + start[1] + 1
        target = (goal[0] + 1) * w + goal[1] + 1
        cost = self._cost
        heuristic = self._heuristic(*goal)
        inf = math.inf
        g = [inf] * len(cost)
        parent = [-1] * len(cost)
        closed = bytearray(len(cost))
        g[source] = 0.0
        heap = [(heuristic[source], source)]
        push, pop = heapq.heappush, heapq.heappop
        orthogonal = tuple((offset, half_step) for offset, half_step, side, _ in self._moves if not side)
        diagonal = tuple(move for move in self._moves if move[2])
        expanded = 0
        while heap:
            here = pop(heap)[1]
            if closed[here]:
                continue
            closed[here] = 1
            expanded += 1
            if here == target:
                break
            g_here = g[here]
            cost_here = cost[here]
            for offset, half_step in orthogonal:
                there = here + offset
                cost_there = cost[there]
                if cost_there == inf or closed[there]:
                    continue
                g_there = g_here + half_step * (cost_here + cost_there)
                if g_there < g[there]:
                    g[there] = g_there
                    parent[there] = here
                    push(heap, (g_there + heuristic[there], there))
            for offset, half_step, side_a, side_b in diagonal:
                there = here + offset
                cost_there = cost[there]
                if cost_there == inf or closed[there] or cost[here + side_a] == inf or cost[here + side_b] == inf:
                    continue
                g_there = g_here + half_step * (cost_here + cost_there)
                if g_there < g[there]:
                    g[there] = g_there
                    parent[there] = here
                    push(heap, (g_there + heuristic[there], there))
        if not closed[target]:
            return None, inf, expanded
        chain = [target]
        while chain[-1] != source:
            chain.append(parent[chain[-1]])
        flat = np.array(chain[::-1])
        cells = np.stack([flat // w - 1, flat % w - 1], axis=1)
        return cells, g[target], expanded
