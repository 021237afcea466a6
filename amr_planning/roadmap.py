"""The course's probabilistic roadmap (PRM): random nodes in free space, straight edges, A* on the graph.

Build (once per map and seed):
  1. `node_count` nodes uniform over the free space: a cell drawn uniformly among the cells
     clear of the inflated obstacles (robot radius + safety margin), then a uniform point inside it
     (the course's "uniform in the map bounds, rejected unless in the safe polygon", without the
     rejections);
  2. an edge between every two nodes closer than `connection_distance` (a k-d tree finds the
     pairs) whose segment stays clear of the inflated obstacles, weighted by its length.
Query: start and goal join the graph through every node they see within `connection_distance`
(or directly, if they see each other; these joins need only stay out of the lethal cells, so a
robot inside the margin can leave it), then A* with the Euclidean distance to the goal as the
heuristic (admissible: edges are straight segments weighted by length). Narrow passages, where no
cell clears the margin, are closed to the roadmap: grid A* crosses them.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from amr_planning.astar import GridPath
from amr_planning.costmap import Costmap
from amr_planning.endpoints import Endpoint, resolve
from amr_planning.errors import PlanningError, Reason
from amr_util.parameter_spec import Config, parameter


@dataclass(frozen=True)
class RoadmapConfig(Config):
    node_count: int = parameter(400, minimum=1, maximum=1_000_000)
    """random nodes (course: 250)."""
    connection_distance: float = parameter(0.6, minimum=0.01, maximum=100.0)
    """m, the longest edge tried (course: 0.15-0.3 on its 2-2.4 m maps)."""
    seed: int = parameter(0, minimum=0, maximum=2**31 - 1)
    """the same seed and map give the same roadmap."""
    snap_distance: float = parameter(0.3, above=0.0, maximum=5.0)
    """m, how far a start or goal in the inflated band may be moved to a free cell."""


class Roadmap:
    """A roadmap built on one costmap; `plan` answers queries on it."""

    def __init__(self, costmap: Costmap, config: RoadmapConfig | None = None) -> None:
        began = time.perf_counter()
        self.costmap = costmap
        self.config = config or RoadmapConfig()
        rng = np.random.default_rng(self.config.seed)
        free_rows, free_cols = np.nonzero(~costmap.inflated)
        if free_rows.size == 0:
            raise PlanningError(Reason.UNREACHABLE, "the map has no cell where the robot fits with its safety margin")
        pick = rng.integers(0, free_rows.size, self.config.node_count)
        corner = costmap.centre(free_rows[pick], free_cols[pick]) - 0.5 * costmap.resolution
        self.nodes = corner + rng.uniform(0.0, costmap.resolution, (self.config.node_count, 2))
        self._tree = cKDTree(self.nodes)
        pairs = self._tree.query_pairs(self.config.connection_distance, output_type="ndarray")
        if len(pairs):
            pairs = pairs[costmap.segments_free(self.nodes[pairs[:, 0]], self.nodes[pairs[:, 1]], costmap.inflated)]
        self.edges = pairs
        self._neighbours: list[list[tuple[int, float]]] = [[] for _ in range(len(self.nodes))]
        lengths = np.hypot(*(self.nodes[pairs[:, 0]] - self.nodes[pairs[:, 1]]).T) if len(pairs) else []
        for (a, b), length in zip(pairs.tolist(), list(lengths), strict=True):
            self._neighbours[a].append((b, length))
            self._neighbours[b].append((a, length))
        self.build_seconds = time.perf_counter() - began

    def plan(self, start, goal) -> GridPath:
        """The shortest roadmap path from start (x, y) to goal (x, y); PlanningError if there is none."""
        began = time.perf_counter()
        start_end = resolve(self.costmap, start, "start", self.config.snap_distance)
        goal_end = resolve(self.costmap, goal, "goal", self.config.snap_distance)
        source, target = self._anchor(start_end), self._anchor(goal_end)
        graph_start, graph_goal = len(self.nodes), len(self.nodes) + 1  # their ids in the search
        points = np.vstack([self.nodes, source, target])
        extra: dict[int, list[tuple[int, float]]] = {graph_start: [], graph_goal: []}
        for anchor_id, anchor in ((graph_start, source), (graph_goal, target)):
            for node in self._visible_nodes(anchor):
                length = float(np.hypot(*(self.nodes[node] - anchor)))
                extra[anchor_id].append((node, length))
                extra.setdefault(node, []).append((anchor_id, length))
        if self.costmap.segments_free(source[None], target[None])[0]:
            direct = float(np.hypot(*(target - source)))
            extra[graph_start].append((graph_goal, direct))
        route, cost, expanded = self._search(points, extra, graph_start, graph_goal)
        if route is None:
            raise PlanningError(
                Reason.UNREACHABLE,
                f"the roadmap ({len(self.nodes)} nodes, {len(self.edges)} edges, seed {self.config.seed}) joins no "
                f"route from ({start_end.point[0]:.3f}, {start_end.point[1]:.3f}) to "
                f"({goal_end.point[0]:.3f}, {goal_end.point[1]:.3f}); more nodes or a longer connection_distance may",
            )
        path = points[route]
        if start_end.snapped:
            path = np.vstack([start_end.point, path])
        return GridPath(path, cost, expanded, time.perf_counter() - began)

    def _anchor(self, end: Endpoint) -> np.ndarray:
        """Where an endpoint joins the graph: itself, or the centre of its free cell if it was snapped."""
        return end.point if not end.snapped else self.costmap.centre(*end.cell)

    def _visible_nodes(self, point: np.ndarray) -> list[int]:
        near = self._tree.query_ball_point(point, self.config.connection_distance)
        if not near:
            return []
        near = np.asarray(near)
        free = self.costmap.segments_free(np.repeat(point[None], len(near), axis=0), self.nodes[near])
        return near[free].tolist()

    def _search(self, points: np.ndarray, extra, source: int, target: int):
        """A* over the roadmap plus the query's extra edges: (node ids, cost, expanded) or (None, inf, n)."""
        goal = points[target]
        heuristic = np.hypot(*(points - goal).T).tolist()
        g = {source: 0.0}
        parent = {source: -1}
        closed = set()
        heap = [(heuristic[source], source)]
        neighbours = self._neighbours
        while heap:
            here = heapq.heappop(heap)[1]
            if here in closed:
                continue
            closed.add(here)
            if here == target:
                route = [here]
                while parent[route[-1]] >= 0:
                    route.append(parent[route[-1]])
                return route[::-1], g[target], len(closed)
            edges = neighbours[here] if here < len(neighbours) else []
            for there, length in edges + extra.get(here, []):
                g_there = g[here] + length
                if g_there < g.get(there, math.inf):
                    g[there] = g_there
                    parent[there] = here
                    heapq.heappush(heap, (g_there + heuristic[there], there))
        return None, math.inf, len(closed)
