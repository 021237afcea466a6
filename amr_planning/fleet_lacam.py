"""LaCAM (`plan_lacam`, Okumura 2023): the fleet's planner. A depth-first search over configurations, PIBT with the
swap of LaCAM3 for each next one, constraints added lazily; complete. Never a rotation round a cycle
(amr_planning.fleet_paths). Restarted with the next seed and twice the budget from 250 configurations: one search's
time is heavy-tailed (bench/bench_fleet_plan.py measures it). Robots in a corridor without a branch or cycle keep
their order: goals in another order are refused before any search.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from amr_planning.errors import PlanningError, Reason
from amr_planning.fleet_lattice import Lattice
from amr_planning.fleet_paths import FleetPlan, check_ends, rotation, trim


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
    (or gives up after `max_nodes` configurations). Not of least cost. PlanningError if two robots share a start or a
    goal, a goal cannot be reached, robots would have to pass each other in a corridor without a branch, or there
    is no plan (or none within `max_nodes`).

    Restarts: the search's time is heavy-tailed, and another seed usually finds a slow search's plan within a few
    hundred configurations. So the search is run with `first_budget` configurations, and, where that is
    not enough, again with the next seed and twice the budget, until `max_nodes` are spent in all (Luby et al.
    1993, "Optimal speedup of Las Vegas algorithms"). A search that runs out of configurations to try proves
    there is no plan, at once."""
    count = check_ends(graph, starts, goals)
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
    return all(b in graph.neighbours[a] and (b, a) not in moves for a, b in moves) and not rotation(config, following)
