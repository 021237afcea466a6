"""LaCAM (amr_planning.fleet_lacam) and the improvement pass (amr_planning.fleet_improve): impossible swaps and
orders refused, six robots in generated tree mazes, no rotation round a cycle, restarts. Plans are checked by the
tests' own code (support.fleet_plans.check)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.fleet_plans import check, components, graph_of, maze_case

from amr_maps.maze_families import generate
from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError
from amr_planning.fleet_execution import dependencies
from amr_planning.fleet_improve import improve
from amr_planning.fleet_lacam import plan_lacam
from amr_planning.fleet_lattice import assign, lattice
from amr_planning.fleet_starts import with_robots


def test_a_swap_in_a_bare_corridor_is_refused_as_impossible():
    graph = graph_of([[0, 0], [1, 0], [2, 0], [3, 0]], [(0, 1), (1, 2), (2, 3)])
    with pytest.raises(PlanningError, match="no plan exists"):
        plan_lacam(graph, [0, 3], [3, 0])


def test_robots_that_must_pass_each_other_in_a_corridor_without_a_branch_are_refused_before_any_search():
    """A single curved corridor: six robots sent each to the next one's start would have to pass each other, which
    no plan can do there. The search would prove it only after every configuration reachable (hundreds of
    thousands: minutes); the order check refuses it with 0 configurations tried. In their own order they are
    planned."""
    data = with_robots(generate("curved", 0, size=4.0), 6, 0)
    costmap = Costmap(rasterize_world(world_from_dict(data), 0.025))
    graph = lattice(costmap, 0.4)
    assert components(graph) == 1 and max(len(n) for n in graph.neighbours) == 2
    starts = assign(graph, costmap, [robot["start"][:2] for robot in data["robots"]])
    goals = [graph.nearest(*robot["goal"][:2]) for robot in data["robots"]]
    with pytest.raises(PlanningError, match="corridor without a branch"):
        plan_lacam(graph, starts, goals, max_nodes=1)
    end = next(v for v, n in enumerate(graph.neighbours) if len(n) == 1)
    position = graph.distances(end)
    order = sorted(range(6), key=lambda robot: position[starts[robot]])
    free = [v for v in np.argsort(position) if v not in starts][-6:]  # six free vertices at the far end, in order
    kept = [0] * 6
    for robot, vertex in zip(order, free, strict=True):
        kept[robot] = int(vertex)
    check(plan_lacam(graph, starts, kept), starts, kept)


@pytest.mark.parametrize("seed", [1, 6, 9])
def test_lacam_plans_six_robots_in_generated_tree_mazes_and_improve_keeps_them_valid(seed):
    """Seeds where the traffic rules leave robots short (docs/fleet.md): every robot is sent to the next one's
    start, all at once."""
    data, costmap, pitch = maze_case(seed)
    graph = lattice(costmap, pitch)
    starts = [graph.nearest(*robot["start"][:2]) for robot in data["robots"]]
    goals = [graph.nearest(*robot["goal"][:2]) for robot in data["robots"]]
    plan = plan_lacam(graph, starts, goals)
    check(plan, starts, goals)
    better = improve(plan)
    check(better, starts, goals)
    moves = [
        sum(a != b for a, b in zip(path[:-1], path[1:], strict=True))
        for path in (plan.paths, better.paths)
        for path in path
    ]
    assert sum(moves[6:]) <= sum(moves[:6])
    assert better.makespan <= plan.makespan
    lower = sum(int(graph.distances(goal)[start]) for start, goal in zip(starts, goals, strict=True))
    assert sum(moves[6:]) >= lower


def test_no_step_of_a_plan_is_a_rotation_round_a_cycle_of_the_lattice():
    """Robots on a cycle of the lattice each sent to the next vertex: in the model they may all move at once round
    it, but robots at their own speeds would then wait on each other for ever (the dependencies form a cycle).
    Such a step is never planned: four robots on a bare square have no plan; five on a ring of six take turns
    through the free vertex."""
    bare = graph_of([[0, 0], [1, 0], [1, 1], [0, 1]], [(0, 1), (1, 2), (2, 3), (3, 0)])
    with pytest.raises(PlanningError, match="no plan exists"):
        plan_lacam(bare, [0, 1, 2, 3], [1, 2, 3, 0])
    ring = graph_of(
        [[math.cos(k * math.pi / 3), math.sin(k * math.pi / 3)] for k in range(6)], [(k, (k + 1) % 6) for k in range(6)]
    )
    starts, goals = [0, 1, 2, 3, 4], [1, 2, 3, 4, 5]
    for plan in (plan_lacam(ring, starts, goals), improve(plan_lacam(ring, starts, goals))):
        check(plan, starts, goals)
        dependencies(plan)  # would raise PlanningError on a cycle
        for step in range(1, max(len(path) for path in plan.paths)):
            at = [[path[min(t, len(path) - 1)] for path in plan.paths] for t in (step - 1, step)]
            onto = {a: b for a, b in zip(*at, strict=True) if a != b}
            assert not (len(onto) == 6 or set(onto) == set(onto.values()) and onto), f"rotation at step {step}"


@pytest.mark.parametrize("starts", [[22, 17, 12, 31, 20, 28], [35, 15, 10, 19, 34, 17], [10, 13, 20, 24, 15, 22]])
def test_lacam_restarts_find_plans_one_long_search_does_not(starts):
    """Six robots from starts where one search (seed 0) runs out of 3000 configurations on `perfect 15`'s lattice;
    restarting with the next seed and twice the budget from 250 finds each plan within the same 3000 (random
    starts there took one search up to 107 s: bench/bench_fleet_plan.py)."""
    data, costmap, pitch = maze_case(15)
    graph = lattice(costmap, pitch)
    goals = [graph.nearest(*robot["goal"][:2]) for robot in data["robots"]]
    with pytest.raises(PlanningError, match="within 3000 configurations"):
        plan_lacam(graph, starts, goals, max_nodes=3000, first_budget=3000)
    plan = plan_lacam(graph, starts, goals, max_nodes=3000)
    check(plan, starts, goals)
    assert plan.nodes <= 3000
