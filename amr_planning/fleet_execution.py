"""Following a fleet plan at the robots' own speeds: its action dependencies and how long it takes.

- **Action dependencies** (`dependencies`, Hoenig et al. 2016, "Multi-agent path finding with kinematic
  constraints"): each robot's plan, waits dropped, is a list of actions (move into a vertex); an action of robot j
  into v depends on every robot i that the plan puts at v earlier having made its next move (left v). A fleet that
  starts an action only when its dependencies are done never puts two robots on one vertex and never deadlocks,
  whatever each robot's speed, as long as the dependencies have no cycle (checked). amr_navigation.fleet_schedule
  follows a plan so.
- **Execution time** (`execution_time`): how long a plan takes followed so, each move and turn timed (the critical
  path through the dependencies); the fleet planner keeps, of several plans, the one that ends first.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from amr_planning.errors import PlanningError, Reason
from amr_planning.fleet_paths import FleetPlan, actions_of


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
    actions = [actions_of(path) for path in plan.paths]
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
