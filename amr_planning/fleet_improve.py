"""Improving a fleet plan (`improve`): each robot planned again around the others' paths, fewest moves first (PIBT
leaves back-and-forth moves); no plan gets more moves or a later end, and none a rotation round a cycle.
"""

from __future__ import annotations

import itertools

from amr_planning.fleet_lattice import Lattice
from amr_planning.fleet_paths import FleetPlan, rotates, trim
from amr_planning.fleet_space_time import Constraints, best_first, constraints_around


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


def _moves(path) -> int:
    return sum(1 for a, b in itertools.pairwise(path) if a != b)


def _fewest_moves(graph: Lattice, start: int, goal: int, constraints: Constraints, horizon: int) -> list[int] | None:
    """The path from start to goal, at the goal for good by step `horizon`, of fewest moves and then earliest
    arrival, obeying the constraints (Dijkstra over (vertex, step)); None if none."""

    def moves(key, vertex, other, step):
        return (0, 0) if key is None else (key[0] + (other != vertex), step)

    return best_first(graph, start, goal, constraints, horizon, moves)
