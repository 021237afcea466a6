"""A fleet's plan on a lattice (`FleetPlan`) and the step model every fleet planner keeps (amr_planning.fleet_lacam,
fleet_cbs, fleet_improve; docs/amr_planning.md).

Time runs in steps; in a step a robot moves to a neighbour or waits. A plan never puts two robots on one vertex in
one step (a *vertex* conflict) nor lets two swap along an edge (an *edge* conflict); a robot may enter a vertex in
the step another leaves it (following). A step in which robots move round a cycle of the lattice, each into the
vertex the next one leaves (a `rotation`), is allowed by the model but never planned: robots at their own speeds
would wait on each other for ever (amr_planning.fleet_execution.dependencies refuses such a plan). A robot done
holds its goal: a path's last vertex stands for every later step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from amr_planning.errors import PlanningError, Reason
from amr_planning.fleet_lattice import Lattice


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
        return sum(arrival_step(path) for path in self.paths)

    @property
    def makespan(self) -> int:
        return max(arrival_step(path) for path in self.paths)

    def vertices(self, robot: int) -> list[int]:
        """The vertices the robot drives through (its path with the waits dropped)."""
        return [vertex for vertex, _ in actions_of(self.paths[robot])]

    def waypoints(self, robot: int) -> np.ndarray:
        """(K, 2) the points the robot drives through (its vertices with the waits dropped)."""
        return self.graph.points[self.vertices(robot)]


def arrival_step(path) -> int:
    """The step from which a path stays at its last vertex."""
    last = len(path) - 1
    while last > 0 and path[last - 1] == path[-1]:
        last -= 1
    return last


def vertex_at(path: list[int], step: int) -> int:
    """The vertex the path is at in `step` (its last one from its end on)."""
    return path[min(step, len(path) - 1)]


def actions_of(path) -> list[tuple[int, int]]:
    """(vertex, step) of each move of a path, waits dropped; the first is the start at step 0."""
    actions = [(path[0], 0)]
    for step in range(1, len(path)):
        if path[step] != path[step - 1]:
            actions.append((path[step], step))
    return actions


def trim(path: tuple[int, ...]) -> tuple[int, ...]:
    """The path without the steps it waits at its goal at the end."""
    return path[: arrival_step(path) + 1]


def check_ends(graph: Lattice, starts: list[int], goals: list[int]) -> int:
    """How many robots are asked for; PlanningError if the starts and goals differ in number, one is not a vertex
    of the graph, or two robots share a start or a goal."""
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


def rotation(before, after) -> bool:
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


def rotates(paths) -> bool:
    """Some step of the paths is a rotation (see rotation)."""
    length = max(len(path) for path in paths)
    return any(
        rotation([vertex_at(path, step - 1) for path in paths], [vertex_at(path, step) for path in paths])
        for step in range(1, length)
    )
