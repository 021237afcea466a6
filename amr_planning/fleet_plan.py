"""Planning several robots together (multi-agent path finding, MAPF) on a lattice of the free space.

Why (docs/fleet.md): the fleet's traffic rules (amr_navigation.traffic) let each robot decide alone.
In a tree maze a dead end that holds several goals must be entered deepest goal first and left in the reverse
order, and no rule of one robot knows that. Planning the robots together settles it: at library level,
amr_evaluation.fleet_navigation's `coordination="plan"` drives a fleet along such a plan
(amr_navigation.fleet_schedule), and through ROS the fleet_planner node hands each robot's navigator its part
(amr_navigation.fleet_planner_node, docs/amr_navigation.md).

1. **Lattice** (`lattice`): `grid_lattice`, points `spacing` m apart, kept where the robot fits clear of the
   safety margin (outside the costmap's inflated cells); an edge joins two 4-neighbours whose segment stays
   outside the inflated cells. The grid is shifted by the offset (of `steps` x `steps` tried over one spacing)
   that keeps the most edges, and of those the one farthest from the walls (the clearance summed over the
   points): in a maze of cells `spacing` wide, the cell centres. A corridor at an angle to the grid (a rotated
   maze, bends, curves) leaves such a grid in pieces; where it does not follow the free space
   (`follows_free_space`) the lattice is `sampled_lattice` instead: points spread along the free space, joined
   where their geodesic Voronoi cells touch. Time runs in steps; in a step a robot moves to a neighbour
   or waits. A plan must never put two robots on one vertex in one step (a *vertex* conflict) nor let two swap
   along an edge (an *edge* conflict); a robot may enter a vertex in the step another leaves it (following).
2. **Conflict-based search** (`plan_together`, Sharon et al. 2015, "Conflict-based search for optimal
   multi-agent pathfinding"). Low level: each robot's shortest path in space and time (A* over (vertex, step),
   the heuristic its lattice distance to the goal, exact) obeying its constraints; a robot done stays at its
   goal. High level: best first by the sum of the paths' steps, the first conflict of the paths splits a node in
   two, each forbidding it to one of the two robots (i may not be at v at t / may not move u -> v arriving at
   t), and that robot is planned again. The first node without a conflict is a plan of least cost. Exponential
   in the worst case; it gives up after `max_nodes` nodes: it is the least-cost reference for small fleets, and a
   step in which robots move round a cycle of the lattice is not a conflict to it (`dependencies` refuses such a
   plan).
3. **LaCAM** (`plan_lacam`, Okumura 2023): a depth-first search over configurations, PIBT with the swap of
   LaCAM3 for each next one, constraints added lazily; complete. What the fleet uses. Never a rotation round a
   cycle. Restarted with the next seed and twice the budget from 250 configurations: one search's time is
   heavy-tailed (bench/bench_fleet_plan.py measures it).
4. **Improvement** (`improve`): each robot planned again around the others' paths, fewest moves first (PIBT
   leaves back-and-forth moves); no plan gets more moves or a later end.
5. **Action dependencies** (`dependencies`, Hoenig et al. 2016, "Multi-agent path finding with kinematic
   constraints"): each robot's plan, waits dropped, is a list of actions (move into a vertex); an action of
   robot j into v depends on every robot i that the plan puts at v earlier having made its next move (left v).
   A fleet that starts an action only when its dependencies are done never puts two robots on one vertex and
   never deadlocks, whatever each robot's speed, as long as the dependencies have no cycle (checked).
6. **Execution time** (`execution_time`): how long a plan takes followed so, each move and turn timed (the
   critical path through the dependencies); the fleet planner keeps, of several plans, the one that ends first.
"""

from __future__ import annotations

import heapq
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


# -- low level: one robot in space and time --------------------------------------------------------------


@dataclass(frozen=True)
class _Constraints:
    vertices: frozenset = frozenset()
    """(vertex, step) the robot may not be at."""
    edges: frozenset = frozenset()
    """(from, to, step) moves the robot may not make (arriving at step)."""
    held: tuple = ()
    """(vertex, step): from that step on the vertex is another robot's for good (it is at its goal)."""

    def latest(self, vertex: int) -> int:
        """The last step a vertex constraint forbids `vertex` (-1 none)."""
        return max((step for v, step in self.vertices if v == vertex), default=-1)

    def horizon(self) -> int:
        return max(
            [step for _, step in self.vertices]
            + [step for _, _, step in self.edges]
            + [step for _, step in self.held]
            + [0]
        )


def space_time_path(
    graph: Lattice, start: int, goal: int, to_goal: np.ndarray, constraints: _Constraints
) -> list[int] | None:
    """The shortest path in space and time from start to goal (one vertex per step, the goal held from its
    last step on) obeying the constraints: A*, the lattice distance to the goal as the heuristic; None if none."""
    if to_goal[start] < 0:
        return None

    def estimate(key, vertex, other, step):
        return None if to_goal[other] < 0 else (step + int(to_goal[other]),)

    return _search(graph, start, goal, constraints, constraints.horizon() + len(graph) + 1, estimate)


def _search(graph: Lattice, start: int, goal: int, constraints: _Constraints, limit: int, priority) -> list[int] | None:
    """Best first over (vertex, step) up to step `limit`, from start to the goal held for good (after the last step a
    constraint forbids it), never where the constraints forbid; `priority(key, vertex, other, step)` gives the key
    of stepping from vertex to other (key: the step's parent key, None at the start; None: do not step there).
    The path (a vertex per step), None if none."""
    held = dict(constraints.held)
    if goal in held or (start, 0) in constraints.vertices:
        return None  # another robot ends at the goal, or stands at the start
    settle = constraints.latest(goal)
    counter = itertools.count()
    frontier = [(priority(None, start, start, 0), next(counter), start, 0)]
    parent: dict[tuple[int, int], tuple[int, int] | None] = {(start, 0): None}
    while frontier:
        key, _, vertex, step = heapq.heappop(frontier)
        if vertex == goal and step > settle:
            path = [vertex]
            state = parent[(vertex, step)]
            while state is not None:
                path.append(state[0])
                state = parent[state]
            return path[::-1]
        if step >= limit:
            continue
        for other in (vertex,) + graph.neighbours[vertex]:
            state = (other, step + 1)
            if state in parent or state in constraints.vertices or (vertex, other, step + 1) in constraints.edges:
                continue
            if other in held and step + 1 >= held[other]:
                continue
            following = priority(key, vertex, other, step + 1)
            if following is None:
                continue
            parent[state] = (vertex, step)
            heapq.heappush(frontier, (following, next(counter), other, step + 1))
    return None


# -- high level: conflict-based search --------------------------------------------------------------------


def _at(path: list[int], step: int) -> int:
    return path[min(step, len(path) - 1)]


def _conflicts_of(paths: list[list[int]]):
    """Every conflict of the paths, step by step: (i, j, kind, step, vertex or (u, v)), kind "vertex" (two robots
    at one vertex) or "edge" (two swapping along an edge)."""
    for step in range(max(len(path) for path in paths)):
        seen: dict[int, int] = {}
        for i, path in enumerate(paths):
            vertex = _at(path, step)
            if vertex in seen:
                yield seen[vertex], i, "vertex", step, vertex
            seen[vertex] = i
        if step == 0:
            continue
        moves: dict[tuple[int, int], int] = {}
        for i, path in enumerate(paths):
            u, v = _at(path, step - 1), _at(path, step)
            if u != v:
                if (v, u) in moves:
                    yield moves[(v, u)], i, "edge", step, (u, v)
                moves[(u, v)] = i


def first_conflict(paths: list[list[int]]):
    """The earliest conflict of the paths (see _conflicts_of); None if none."""
    return next(_conflicts_of(paths), None)


@dataclass(frozen=True)
class FleetPlan:
    """A conflict-free plan: one vertex per step for each robot (a robot done holds its goal), on `graph`."""

    graph: Lattice
    paths: tuple[tuple[int, ...], ...]
    nodes: int
    """high-level nodes the search expanded."""

    @property
    def cost(self) -> int:
        """The sum over robots of the steps until each is at its goal for good."""
        return sum(_arrival(path) for path in self.paths)

    @property
    def makespan(self) -> int:
        return max(_arrival(path) for path in self.paths)

    def vertices(self, robot: int) -> list[int]:
        """The vertices the robot drives through (its path with the waits dropped)."""
        return [vertex for vertex, _ in _actions(self.paths[robot])]

    def waypoints(self, robot: int) -> np.ndarray:
        """(K, 2) the points the robot drives through (its vertices with the waits dropped)."""
        return self.graph.points[self.vertices(robot)]


def _arrival(path) -> int:
    """The step from which a path stays at its last vertex."""
    last = len(path) - 1
    while last > 0 and path[last - 1] == path[-1]:
        last -= 1
    return last


def plan_together(graph: Lattice, starts: list[int], goals: list[int], max_nodes: int = 20000) -> FleetPlan:
    """Paths for every robot, starts[i] to goals[i] (lattice vertices), in which no two are ever at one vertex
    and none swap along an edge, with the least sum of steps (conflict-based search; see the module docstring).
    PlanningError if two robots share a start or a goal, a goal cannot be reached, or the search gives up."""
    count = _check(graph, starts, goals)
    to_goal = [graph.distances(goal) for goal in goals]
    constraints = [_Constraints() for _ in range(count)]
    paths = []
    for i in range(count):
        path = space_time_path(graph, starts[i], goals[i], to_goal[i], constraints[i])
        if path is None:
            raise PlanningError(
                Reason.UNREACHABLE,
                f"robot {i}: goal vertex {goals[i]} cannot be reached from start vertex {starts[i]} on the lattice",
            )
        paths.append(path)
    counter = itertools.count()
    open_list = [(_cost(paths), 0, next(counter), constraints, paths)]
    expanded = 0
    while open_list:
        _, _, _, constraints, paths = heapq.heappop(open_list)
        conflict = first_conflict(paths)
        if conflict is None:
            return FleetPlan(graph, tuple(tuple(path) for path in paths), expanded)
        expanded += 1
        if expanded > max_nodes:
            raise PlanningError(
                Reason.UNREACHABLE, f"no conflict-free plan for {count} robots within {max_nodes} search nodes"
            )
        i, j, kind, step, where = conflict
        for robot in (i, j):
            mine = constraints[robot]
            if kind == "vertex":
                mine = _Constraints(mine.vertices | {(where, step)}, mine.edges)
            else:  # forbid the robot its own move of the swap
                u, v = _at(paths[robot], step - 1), _at(paths[robot], step)
                mine = _Constraints(mine.vertices, mine.edges | {(u, v, step)})
            path = space_time_path(graph, starts[robot], goals[robot], to_goal[robot], mine)
            if path is None:
                continue
            child_constraints = list(constraints)
            child_constraints[robot] = mine
            child_paths = list(paths)
            child_paths[robot] = path
            heapq.heappush(
                open_list, (_cost(child_paths), _conflicts(child_paths), next(counter), child_constraints, child_paths)
            )
    raise PlanningError(Reason.UNREACHABLE, f"no conflict-free plan exists for these {count} robots on the lattice")


def _cost(paths: list[list[int]]) -> int:
    return sum(_arrival(path) for path in paths)


def _conflicts(paths: list[list[int]]) -> int:
    """How many conflicts the paths have (the tie-break among nodes of one cost: fewest first)."""
    return sum(1 for _ in _conflicts_of(paths))


# -- execution: action dependencies ----------------------------------------------------------------------


def _actions(path) -> list[tuple[int, int]]:
    """(vertex, step) of each move of a path, waits dropped; the first is the start at step 0."""
    actions = [(path[0], 0)]
    for step in range(1, len(path)):
        if path[step] != path[step - 1]:
            actions.append((path[step], step))
    return actions


def dependencies(plan: FleetPlan) -> list[list[list[tuple[int, int]]]]:
    """For robot i's action a (its a-th vertex, waits dropped; action 0 is its start), the (j, b) that must be
    done first: robot j has made its action b (moved on from a vertex the plan puts it at before i gets there).
    PlanningError if the dependencies form a cycle (robots following one another round a cycle of the lattice
    in one step): the plan could then stall."""
    needs, _ = _action_graph(plan)
    return [
        [sorted({dep for dep in action if dep[0] != robot}) for action in moves] for robot, moves in enumerate(needs)
    ]


def _action_graph(plan: FleetPlan):
    """Every action's needs, its robot's action before it included, and the actions in an order that keeps them
    (see dependencies; PlanningError on a cycle)."""
    actions = [_actions(path) for path in plan.paths]
    visits: dict[int, list[tuple[int, int, int]]] = {}
    for robot, moves in enumerate(actions):
        for index, (vertex, step) in enumerate(moves):
            visits.setdefault(vertex, []).append((step, robot, index))
    needs: list[list[list[tuple[int, int]]]] = [[[] for _ in moves] for moves in actions]
    for vertex, seen in visits.items():
        for step, robot, index in seen:
            for other_step, other, other_index in seen:
                if other == robot or other_step >= step:
                    continue
                if other_index + 1 >= len(actions[other]):
                    raise PlanningError(
                        Reason.INVALID, f"robot {robot} is planned onto vertex {vertex} where robot {other} ends"
                    )
                needs[robot][index].append((other, other_index + 1))
            if index > 0:
                needs[robot][index].append((robot, index - 1))
    return needs, _topological_order(needs)


def _topological_order(needs) -> list[tuple[int, int]]:
    """Every action (robot, index) after those it needs (Kahn's algorithm); PlanningError on a cycle."""
    nodes = [(robot, index) for robot, moves in enumerate(needs) for index in range(len(moves))]
    waiting = {node: len(set(needs[node[0]][node[1]])) for node in nodes}
    users: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for node in nodes:
        for dep in set(needs[node[0]][node[1]]):
            users.setdefault(dep, []).append(node)
    ready = deque(node for node, count in waiting.items() if count == 0)
    order = []
    while ready:
        node = ready.popleft()
        order.append(node)
        for user in users.get(node, ()):
            waiting[user] -= 1
            if waiting[user] == 0:
                ready.append(user)
    if len(order) != len(nodes):
        raise PlanningError(
            Reason.INVALID,
            "the plan's action dependencies form a cycle (robots following one "
            "another round a cycle of the lattice): it could stall",
        )
    return order


def execution_time(plan: FleetPlan, speed: float = 0.2, turn_rate: float = 1.0) -> float:
    """s until the last robot is at its goal vertex when each robot drives from vertex to vertex at `speed` m/s,
    turns in place at `turn_rate` rad/s where its way bends, and starts each move as soon as the moves it depends on
    are done (the action-dependency execution of amr_navigation.fleet_schedule). The makespan counts steps as if
    every robot moved in lockstep; driven this way a robot waits for the moves it depends on, not for a step, and a
    plan of more steps may end sooner (`perfect 9`: makespans 95 and 112 steps, estimates 439 and 352 s). The
    longest path through the dependencies (a critical path, as in Hoenig et al. 2019, "Persistent and robust
    execution of MAPF schedules in warehouses"):

        T(i, 0) = 0,   T(i, a) = max(T(i, a-1), max over (j, b) in needs(i, a) of T(j, b)) + d(i, a),
        d(i, a) = |p(i, a) - p(i, a-1)| / speed + |heading change at p(i, a-1)| / turn_rate."""
    if not (math.isfinite(speed) and speed > 0.0 and math.isfinite(turn_rate) and turn_rate > 0.0):
        raise ValueError(f"execution_time: speed and turn_rate must be positive numbers, got {speed!r}, {turn_rate!r}")
    needs, order = _action_graph(plan)
    points = plan.graph.points
    ways = [points[plan.vertices(robot)] for robot in range(len(plan.paths))]
    finish: dict[tuple[int, int], float] = {}
    for robot, index in order:
        if index == 0:
            finish[robot, 0] = 0.0
            continue
        way = ways[robot]
        duration = float(np.hypot(*(way[index] - way[index - 1]))) / speed
        if index >= 2:
            before, after = way[index - 1] - way[index - 2], way[index] - way[index - 1]
            turn = math.atan2(before[0] * after[1] - before[1] * after[0], float(before @ after))
            duration += abs(turn) / turn_rate
        finish[robot, index] = max(finish[dep] for dep in needs[robot][index]) + duration  # its own last move too
    return max((finish[robot, len(way) - 1] for robot, way in enumerate(ways)), default=0.0)


# -- LaCAM: a complete search over configurations, PIBT for the next one ----------------------------------


@dataclass
class _Constraint:
    """A low-level node of LaCAM: robots order[0..depth-1] are told where to go next (who[k] to where[k])."""

    who: tuple[int, ...] = ()
    where: tuple[int, ...] = ()


@dataclass
class _Node:
    config: tuple[int, ...]
    parent: _Node | None
    priorities: list[float]
    tree: deque

    @property
    def order(self) -> list[int]:
        """The robots, highest priority first."""
        return sorted(range(len(self.config)), key=lambda i: -self.priorities[i])


MAX_NODES = 200000
"""configurations plan_lacam searches at most by default (over all its restarts)."""


def plan_lacam(
    graph: Lattice,
    starts: list[int],
    goals: list[int],
    max_nodes: int = MAX_NODES,
    seed: int = 0,
    first_budget: int = 250,
) -> FleetPlan:
    """Paths for every robot, starts[i] to goals[i] (lattice vertices), in which no two are ever at one vertex and
    none swap along an edge (LaCAM, Okumura 2023, "LaCAM: search-based algorithm for quick multi-agent
    pathfinding"): a depth-first search over configurations (where every robot is), each next one made by PIBT
    (priority inheritance with backtracking, Okumura et al. 2022: robots in order of priority take their
    neighbour nearest to their goal, and one pushed by a higher-priority robot moves on first or the other tries
    its next neighbour), with constraints on the first robots added lazily, one robot at a time, so that every
    successor of a configuration is tried in the end. Complete: it finds a plan if one exists, else says so
    (or gives up after `max_nodes` configurations). Not of least cost. PlanningError as plan_together.

    Restarts: the search's time is heavy-tailed, and another seed usually finds a slow search's plan within a few
    hundred configurations. So the search is run with `first_budget` configurations, and, where that is
    not enough, again with the next seed and twice the budget, until `max_nodes` are spent in all (Luby et al.
    1993, "Optimal speedup of Las Vegas algorithms"). A search that runs out of configurations to try proves
    there is no plan, at once."""
    count = _check(graph, starts, goals)
    to_goal = [graph.distances(goal) for goal in goals]
    for i in range(count):
        if to_goal[i][starts[i]] < 0:
            raise PlanningError(
                Reason.UNREACHABLE,
                f"robot {i}: goal vertex {goals[i]} cannot be reached from start vertex {starts[i]} on the lattice",
            )
    _check_order_in_corridors(graph, starts, goals)
    spent, attempt = 0, 0
    while True:
        budget = max(1, min(first_budget * 2**attempt, max_nodes - spent))
        plan = _lacam(graph, starts, goals, to_goal, budget, seed + attempt)
        if plan is not None:
            return FleetPlan(graph, plan.paths, spent + plan.nodes)
        spent, attempt = spent + budget, attempt + 1
        if spent >= max_nodes:
            raise PlanningError(
                Reason.UNREACHABLE, f"no plan for {count} robots within {max_nodes} configurations ({attempt} searches)"
            )


def _check_order_in_corridors(graph: Lattice, starts: list[int], goals: list[int]) -> None:
    """PlanningError at once where robots would have to pass each other in a corridor: in a part of the lattice
    that is a bare path (no branch, no cycle: a single corridor, bent or curved), robots keep their order along it
    whatever they do, so goals in another order than the starts have no plan. The search would prove it too, but
    only after trying every configuration reachable: for six robots on 28 vertices that is up to C(28, 6) =
    376,740 of them, minutes of work, where it says so in no time here."""
    robots_of: dict[int, list[int]] = {}
    component = graph.components()
    for robot, start in enumerate(starts):
        robots_of.setdefault(int(component[start]), []).append(robot)
    for part, robots in robots_of.items():
        vertices = np.flatnonzero(component == part)
        degrees = [len(graph.neighbours[v]) for v in vertices]
        edges = sum(degrees) // 2
        if len(robots) < 2 or max(degrees) > 2 or edges != len(vertices) - 1:
            continue  # a branch or a cycle: robots may pass each other there
        end = next(int(v) for v, d in zip(vertices, degrees, strict=True) if d <= 1)
        position = graph.distances(end)
        by_start = sorted(robots, key=lambda robot: position[starts[robot]])
        by_goal = sorted(robots, key=lambda robot: position[goals[robot]])
        if by_start != by_goal:
            first = next(i for i, (a, b) in enumerate(zip(by_start, by_goal, strict=True)) if a != b)
            raise PlanningError(
                Reason.UNREACHABLE,
                f"no plan exists: robots {by_start} stand in a corridor without a "
                f"branch in that order and their goals are in the order {by_goal} "
                f"(robot {by_start[first]} would have to pass another)",
            )


def _lacam(graph: Lattice, starts, goals, to_goal, max_nodes: int, seed: int) -> FleetPlan | None:
    """One LaCAM search (see plan_lacam) with the seed's tie-breaks: the plan, None after `max_nodes`
    configurations, PlanningError when every configuration reachable was searched."""
    count = len(starts)
    rng = np.random.default_rng(seed)
    target = tuple(goals)
    start = tuple(starts)
    pibt = _Pibt(graph, goals, to_goal, rng)
    root = _Node(start, None, _priorities(start, to_goal, None), deque([_Constraint()]))
    explored = {start: root}
    stack = [root]
    generated = 0
    while stack:
        node = stack[-1]
        if node.config == target:
            configs = []
            while node is not None:
                configs.append(node.config)
                node = node.parent
            configs.reverse()
            paths = tuple(tuple(config[i] for config in configs) for i in range(count))
            return FleetPlan(graph, tuple(trim(path) for path in paths), generated)
        if not node.tree:
            stack.pop()
            continue
        constraint = node.tree.popleft()
        depth = len(constraint.who)
        if depth < count:
            robot = node.order[depth]
            options = list((node.config[robot],) + graph.neighbours[node.config[robot]])
            rng.shuffle(options)
            for vertex in options:
                node.tree.append(_Constraint(constraint.who + (robot,), constraint.where + (vertex,)))
        following = pibt.step(node.config, node.order, constraint)
        if following is None:
            continue
        known = explored.get(following)
        if known is not None:
            stack.append(known)  # reach it again (its search goes on from where it stopped)
            continue
        generated += 1
        if generated > max_nodes:
            return None
        child = _Node(following, node, _priorities(following, to_goal, node.priorities), deque([_Constraint()]))
        explored[following] = child
        stack.append(child)
    raise PlanningError(
        Reason.UNREACHABLE,
        f"no plan exists for these {count} robots on the lattice (every configuration reachable was searched)",
    )


def _check(graph: Lattice, starts: list[int], goals: list[int]) -> int:
    count = len(starts)
    if len(goals) != count:
        raise PlanningError(Reason.INVALID, f"{count} starts but {len(goals)} goals")
    for what, vertices in (("start", starts), ("goal", goals)):
        for vertex in vertices:
            if not 0 <= vertex < len(graph):
                raise PlanningError(Reason.INVALID, f"{what} vertex {vertex} is not on the lattice of {len(graph)}")
        if len(set(vertices)) != count:
            raise PlanningError(Reason.INVALID, f"two robots share a {what} vertex: {list(vertices)}")
    return count


def _priorities(config, to_goal, previous) -> list[float]:
    """PIBT's dynamic priorities: a robot not at its goal gains 1 each step; one at its goal drops to the fraction
    (at first: its distance to the goal / 10000, a tie-break)."""
    if previous is None:
        return [float(to_goal[i][config[i]]) / 10000.0 for i in range(len(config))]
    return [previous[i] + 1.0 if to_goal[i][config[i]] else previous[i] - int(previous[i]) for i in range(len(config))]


class _Pibt:
    """One next configuration by PIBT with the swap of LaCAM3 (Okumura 2024, "Engineering LaCAM*"): a robot that
    must pass another head on in a corridor pulls it back along to a junction where the two can swap, instead of
    pushing it on."""

    def __init__(self, graph: Lattice, goals, to_goal, rng) -> None:
        self.graph, self.goals, self.to_goal, self.rng = graph, goals, to_goal, rng

    def step(self, config, order, constraint: _Constraint) -> tuple[int, ...] | None:
        self.config = config
        self.now = {vertex: robot for robot, vertex in enumerate(config)}
        self.next: dict[int, int] = {}
        self.to: list[int] = [-1] * len(config)
        for robot, vertex in zip(constraint.who, constraint.where, strict=True):
            self.to[robot] = vertex
        for robot, vertex in zip(constraint.who, constraint.where, strict=True):
            if vertex in self.next:
                return None
            occupant = self.now.get(vertex)
            if occupant is not None and occupant != robot and self.to[occupant] == config[robot]:
                return None  # a swap
            self.next[vertex] = robot
        for robot in order:
            if self.to[robot] < 0 and not self._push(robot):
                return None
        following = tuple(self.to)
        return following if _valid_step(self.graph, config, following) else None

    def _push(self, i: int) -> bool:
        here = self.config[i]
        options = list(self.graph.neighbours[here]) + [here]
        ties = self.rng.random(len(options))
        options = [options[k] for k in np.argsort([self.to_goal[i][v] + t for v, t in zip(options, ties, strict=True)])]
        swap = self._swap_partner(i, options)
        if swap is not None:
            options.reverse()
        for k, vertex in enumerate(options):
            if vertex in self.next:
                continue
            j = self.now.get(vertex)
            if j is not None and self.to[j] == here:
                continue  # a swap
            self.next[vertex] = i
            self.to[i] = vertex
            if j is not None and vertex != here and self.to[j] < 0 and not self._push(j):
                continue
            if swap is not None and k == 0 and self.to[swap] < 0 and here not in self.next:
                self.next[here] = swap  # pull the other robot back along
                self.to[swap] = here
            return True
        self.next[here] = i
        self.to[i] = here
        return False

    def _swap_partner(self, i: int, options: list[int]) -> int | None:
        """The robot i must swap with (pull back along) rather than push, if any (LaCAM3's
        is_swap_required_and_possible)."""
        here, best = self.config[i], options[0]
        j = self.now.get(best)
        if (
            j is not None
            and j != i
            and self.to[j] < 0
            and self._required(i, j, here, self.config[j])
            and self._possible(self.config[j], here)
        ):
            return j
        if best != here:  # clearing the way, as in push and swap
            for u in self.graph.neighbours[here]:
                k = self.now.get(u)
                if (
                    k is not None
                    and best != self.config[k]
                    and self._required(k, i, here, best)
                    and self._possible(best, here)
                ):
                    return k
        return None

    def _pullable(self, puller: int, pusher: int) -> tuple[int, int]:
        """How many neighbours of vertex `puller` a pulled robot could step to (not `pusher`, not a dead end
        where a robot stands at its goal), and one of them."""
        n, other = 0, -1
        for u in self.graph.neighbours[puller]:
            occupant = self.now.get(u)
            if u == pusher or (
                len(self.graph.neighbours[u]) == 1 and occupant is not None and self.goals[occupant] == u
            ):
                continue
            n += 1
            other = u
        return n, other

    def _required(self, pusher: int, puller: int, v_pusher: int, v_puller: int) -> bool:
        """The two must swap: pushing the other on along the corridor would take it away from its goal."""
        distance = self.to_goal[pusher]
        while distance[v_puller] < distance[v_pusher]:
            n, other = self._pullable(v_puller, v_pusher)
            if n >= 2:
                return False  # they can pass each other there
            if n <= 0:
                break
            v_pusher, v_puller = v_puller, other
        mine = self.to_goal[puller]
        return bool(
            mine[v_pusher] < mine[v_puller] and (distance[v_pusher] == 0 or distance[v_puller] < distance[v_pusher])
        )

    def _possible(self, v_pusher: int, v_puller: int) -> bool:
        """Pulling back along the corridor reaches a junction where the two can swap."""
        origin = v_pusher
        while v_puller != origin:
            n, other = self._pullable(v_puller, v_pusher)
            if n >= 2:
                return True
            if n <= 0:
                return False
            v_pusher, v_puller = v_puller, other
        return False


def _valid_step(graph, config, following) -> bool:
    """No two robots at one vertex, none swapping, every move along an edge, no rotation."""
    if len(set(following)) != len(following):
        return False
    moves = {(a, b) for a, b in zip(config, following, strict=True) if a != b}
    return all(b in graph.neighbours[a] and (b, a) not in moves for a, b in moves) and not _rotation(config, following)


def _rotation(before, after) -> bool:
    """Robots moving round a cycle of the lattice in one step, each into the vertex the next one leaves (allowed
    by the model, but the dependencies of such a step form a cycle: robots at their own speeds would wait on
    each other for ever)."""
    onto = {a: b for a, b in zip(before, after, strict=True) if a != b}
    for first in onto:
        vertex, seen = onto[first], 0
        while vertex in onto and seen <= len(onto):
            if vertex == first:
                return True
            vertex, seen = onto[vertex], seen + 1
    return False


def trim(path: tuple[int, ...]) -> tuple[int, ...]:
    """The path without the steps it waits at its goal at the end."""
    return path[: _arrival(path) + 1]


# -- improving a plan: each robot planned again around the others -------------------------------------------


def improve(plan: FleetPlan, rounds: int = 4) -> FleetPlan:
    """A plan with no more moves and no later end, each robot in turn planned again around the others' paths as
    they stand (a large-neighbourhood search of one robot at a time, as MAPF-LNS does with more): its path of
    fewest moves (then earliest arrival) that never meets theirs and ends by the plan's last step, kept when it
    has fewer moves than before. LaCAM's plans carry the back-and-forth moves of PIBT; a robot that stepped aside
    for nothing now waits instead, one that must make way still does. Stops after `rounds` rounds, or one that
    changed nothing."""
    paths = [list(path) for path in plan.paths]
    goals = [path[-1] for path in paths]
    horizon = max(len(path) for path in paths) - 1
    for _ in range(rounds):
        changed = False
        for robot in sorted(range(len(paths)), key=lambda i: -_moves(paths[i])):
            path = _fewest_moves(plan.graph, paths[robot][0], goals[robot], constraints_around(paths, robot), horizon)
            if path is not None and _moves(path) < _moves(paths[robot]):
                kept, paths[robot] = paths[robot], path
                if rotates(paths):
                    paths[robot] = kept  # it would close a rotation with the others: keep the old path
                else:
                    changed = True
        if not changed:
            break
    return FleetPlan(plan.graph, tuple(tuple(trim(tuple(path))) for path in paths), plan.nodes)


def rotates(paths) -> bool:
    """Some step of the paths is a rotation (see _rotation)."""
    length = max(len(path) for path in paths)
    return any(
        _rotation([_at(path, step - 1) for path in paths], [_at(path, step) for path in paths])
        for step in range(1, length)
    )


def _moves(path) -> int:
    return sum(1 for a, b in itertools.pairwise(path) if a != b)


def _fewest_moves(graph: Lattice, start: int, goal: int, constraints: _Constraints, horizon: int) -> list[int] | None:
    """The path from start to goal, at the goal for good by step `horizon`, of fewest moves and then earliest
    arrival, obeying the constraints (Dijkstra over (vertex, step)); None if none."""

    def moves(key, vertex, other, step):
        return (0, 0) if key is None else (key[0] + (other != vertex), step)

    return _search(graph, start, goal, constraints, horizon, moves)


def constraints_around(paths: list[list[int]], robot: int) -> _Constraints:
    """The constraints that keep one robot clear of the others' paths: never at a vertex where one is, never
    swapping with one, never on a goal one has reached for good."""
    vertices, edges, held = set(), set(), []
    for other, path in enumerate(paths):
        if other == robot:
            continue
        arrival = _arrival(path)
        for step in range(arrival):
            vertices.add((path[step], step))
            if step + 1 <= arrival:
                edges.add((path[step + 1], path[step], step + 1))
        held.append((path[-1], arrival))
    return _Constraints(frozenset(vertices), frozenset(edges), tuple(held))
