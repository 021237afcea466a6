"""One robot's way in space and time among others (the steps of amr_planning.fleet_paths): `Constraints` (vertices
and moves forbidden at given steps, goals other robots hold from a step on), `space_time_path` (the shortest way,
A* over (vertex, step)), `best_first` (the search under any order of preference) and `constraints_around` (what
keeps a robot clear of the others' paths). Used by conflict-based search (fleet_cbs), the improvement pass
(fleet_improve) and the fleet coordinator's partial replans (amr_navigation.fleet_coordinator).
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass

import numpy as np

from amr_planning.fleet_lattice import Lattice
from amr_planning.fleet_paths import arrival_step


@dataclass(frozen=True)
class Constraints:
    """What one robot may not do, step by step."""

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
    graph: Lattice, start: int, goal: int, to_goal: np.ndarray, constraints: Constraints
) -> list[int] | None:
    """The shortest path in space and time from start to goal (one vertex per step, the goal held from its
    last step on) obeying the constraints: A*, the lattice distance to the goal as the heuristic; None if none."""
    if to_goal[start] < 0:
        return None

    def estimate(key, vertex, other, step):
        return None if to_goal[other] < 0 else (step + int(to_goal[other]),)

    return best_first(graph, start, goal, constraints, constraints.horizon() + len(graph) + 1, estimate)


def best_first(
    graph: Lattice, start: int, goal: int, constraints: Constraints, limit: int, priority
) -> list[int] | None:
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


def constraints_around(paths: list[list[int]], robot: int) -> Constraints:
    """The constraints that keep one robot clear of the others' paths: never at a vertex where one is, never
    swapping with one, never on a goal one has reached for good."""
    vertices, edges, held = set(), set(), []
    for other, path in enumerate(paths):
        if other == robot:
            continue
        arrival = arrival_step(path)
        for step in range(arrival):
            vertices.add((path[step], step))
            if step + 1 <= arrival:
                edges.add((path[step + 1], path[step], step + 1))
        held.append((path[-1], arrival))
    return Constraints(frozenset(vertices), frozenset(edges), tuple(held))
