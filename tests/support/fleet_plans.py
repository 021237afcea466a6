"""Shared by the fleet planning tests (tests/planning/test_fleet_*.py): small lattices, generated maze cases, and
checks of the tests' own (not the modules' conflict finder): a plan's validity, a graph's components, a plan carried
out at random speeds."""

from __future__ import annotations

import numpy as np

from amr_maps.maze_families import generate, grid_pitch
from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_planning.costmap import Costmap
from amr_planning.fleet_execution import dependencies
from amr_planning.fleet_lattice import Lattice
from amr_planning.fleet_starts import with_robots


def graph_of(points, edges) -> Lattice:
    neighbours = [[] for _ in points]
    for a, b in edges:
        neighbours[a].append(b)
        neighbours[b].append(a)
    return Lattice(np.asarray(points, dtype=float), tuple(tuple(sorted(n)) for n in neighbours), 1.0)


def corridor_with_pocket() -> Lattice:
    """0-1-2-3-4 in a row, a pocket 5 off vertex 2."""
    return graph_of([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [2, 1]], [(0, 1), (1, 2), (2, 3), (3, 4), (2, 5)])


def check(plan, starts, goals) -> None:
    """The plan's paths start and end where asked, move along edges, never share a vertex, never swap."""
    graph = plan.graph
    paths = [list(path) for path in plan.paths]
    assert [path[0] for path in paths] == list(starts)
    assert [path[-1] for path in paths] == list(goals)
    length = max(len(path) for path in paths)
    at = [[path[min(step, len(path) - 1)] for path in paths] for step in range(length)]
    for step in range(length):
        assert len(set(at[step])) == len(paths), f"two robots on one vertex at step {step}: {at[step]}"
        if step:
            for robot, (a, b) in enumerate(zip(at[step - 1], at[step], strict=True)):
                assert a == b or b in graph.neighbours[a], f"robot {robot} jumps {a} -> {b}"
                for other, (c, d) in enumerate(zip(at[step - 1], at[step], strict=True)):
                    assert not (other != robot and a != b and (a, b) == (d, c)), f"robots {robot}, {other} swap"


def maze_case(seed: int, robots: int = 6):
    data = with_robots(generate("perfect", seed, size=4.0), robots, seed)
    pitch = grid_pitch(data)
    costmap = Costmap(rasterize_world(world_from_dict(data), 0.025))
    return data, costmap, pitch


def components(graph: Lattice) -> int:
    """Connected components of the graph, by a search of the test's own."""
    seen, count = set(), 0
    for first in range(len(graph)):
        if first in seen:
            continue
        count += 1
        stack = [first]
        seen.add(first)
        while stack:
            for other in graph.neighbours[stack.pop()]:
                if other not in seen:
                    seen.add(other)
                    stack.append(other)
    return count


def execute(plan, rng, needs=None) -> list[dict]:
    """Carry the plan out with the dependencies at random speeds: each robot starts its next move once every
    move it depends on is done, and takes 1-5 ticks for it (occupying both vertices meanwhile). The occupancy
    of every tick (a robot's vertices); fails if a robot enters a vertex another occupies, or the fleet stalls."""
    needs = dependencies(plan) if needs is None else needs
    moves = [[path[0]] + [b for a, b in zip(path[:-1], path[1:], strict=True) if a != b] for path in plan.paths]
    done = [0] * len(moves)
    busy = [0] * len(moves)  # ticks left of the move under way (0: standing at moves[r][done[r]])
    history = []
    for _ in range(100000):
        if all(d == len(m) - 1 for d, m in zip(done, moves, strict=True)) and not any(busy):
            return history
        occupied = {}
        for robot in range(len(moves)):
            here = [moves[robot][done[robot]]] + ([moves[robot][done[robot] + 1]] if busy[robot] else [])
            for vertex in here:
                assert vertex not in occupied, f"robots {occupied.get(vertex)} and {robot} both on vertex {vertex}"
                occupied[vertex] = robot
        history.append(occupied)
        progressed = False
        for robot in rng.permutation(len(moves)):
            if busy[robot]:
                busy[robot] -= 1
                if busy[robot] == 0:
                    left = moves[robot][done[robot]]
                    if occupied.get(left) == robot:
                        del occupied[left]
                    done[robot] += 1
                progressed = True
            elif done[robot] + 1 < len(moves[robot]) and all(done[o] >= a for o, a in needs[robot][done[robot] + 1]):
                target = moves[robot][done[robot] + 1]
                if target in occupied and occupied[target] != robot:
                    raise AssertionError(f"robot {robot} may enter {target} while robot {occupied[target]} is there")
                busy[robot] = int(rng.integers(1, 6))
                occupied[target] = robot
                progressed = True
        assert progressed, f"the fleet stalls with progress {done}"
    raise AssertionError("no end")
