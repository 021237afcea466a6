"""Conflict-based search (`plan_together`, Sharon et al. 2015, "Conflict-based search for optimal multi-agent
pathfinding"): the least-cost reference for small fleets, used by the tests (as is `first_conflict`, their check of
a plan), not by the fleet, which is planned by LaCAM (amr_planning.fleet_lacam).

Low level: each robot's shortest path in space and time (amr_planning.fleet_space_time.space_time_path: A* over
(vertex, step), the heuristic its lattice distance to the goal, exact) obeying its constraints; a robot done stays at
its goal. High level: best first by the sum of the paths' steps, the first conflict of the paths splits a node in
two, each forbidding it to one of the two robots (i may not be at v at t / may not move u -> v arriving at t), and
that robot is planned again. The first node without a conflict is a plan of least cost. Exponential in the worst
case; it gives up after `max_nodes` nodes. A step in which robots move round a cycle of the lattice is not a
conflict to it (amr_planning.fleet_execution.dependencies refuses such a plan).
"""

from __future__ import annotations

import heapq
import itertools

from amr_planning.errors import PlanningError, Reason
from amr_planning.fleet_lattice import Lattice
from amr_planning.fleet_paths import FleetPlan, arrival_step, check_ends, vertex_at
from amr_planning.fleet_space_time import Constraints, space_time_path


def _conflicts_of(paths: list[list[int]]):
    """Every conflict of the paths, step by step: (i, j, kind, step, vertex or (u, v)), kind "vertex" (two robots
    at one vertex) or "edge" (two swapping along an edge)."""
    for step in range(max(len(path) for path in paths)):
        seen: dict[int, int] = {}
        for i, path in enumerate(paths):
            vertex = vertex_at(path, step)
            if vertex in seen:
                yield seen[vertex], i, "vertex", step, vertex
            seen[vertex] = i
        if step == 0:
            continue
        moves: dict[tuple[int, int], int] = {}
        for i, path in enumerate(paths):
            u, v = vertex_at(path, step - 1), vertex_at(path, step)
            if u != v:
                if (v, u) in moves:
                    yield moves[(v, u)], i, "edge", step, (u, v)
                moves[(u, v)] = i


def first_conflict(paths: list[list[int]]):
    """The earliest conflict of the paths (see _conflicts_of); None if none."""
    return next(_conflicts_of(paths), None)


def plan_together(graph: Lattice, starts: list[int], goals: list[int], max_nodes: int = 20000) -> FleetPlan:
    """Paths for every robot, starts[i] to goals[i] (lattice vertices), in which no two are ever at one vertex
    and none swap along an edge, with the least sum of steps (conflict-based search; see the module docstring).
    PlanningError if two robots share a start or a goal, a goal cannot be reached, or the search gives up."""
    count = check_ends(graph, starts, goals)
    to_goal = [graph.distances(goal) for goal in goals]
    constraints = [Constraints() for _ in range(count)]
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
                mine = Constraints(mine.vertices | {(where, step)}, mine.edges)
            else:  # forbid the robot its own move of the swap
                u, v = vertex_at(paths[robot], step - 1), vertex_at(paths[robot], step)
                mine = Constraints(mine.vertices, mine.edges | {(u, v, step)})
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
    return sum(arrival_step(path) for path in paths)


def _conflicts(paths: list[list[int]]) -> int:
    """How many conflicts the paths have (the tie-break among nodes of one cost: fewest first)."""
    return sum(1 for _ in _conflicts_of(paths))
