"""Planning several robots together (amr_planning.fleet_*): the lattice of a maze, conflict-based search and
LaCAM on small graphs and generated mazes, the improvement pass, and the action dependencies executed at random
speeds. Plans are checked here by code of the test's own (no two robots at one vertex, no swap, moves along
edges, every robot at its goal), not by fleet_cbs's conflict finder."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_maps.maze_families import generate, grid_pitch
from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError
from amr_planning.fleet_cbs import plan_together
from amr_planning.fleet_execution import dependencies, execution_time
from amr_planning.fleet_improve import improve
from amr_planning.fleet_lacam import plan_lacam
from amr_planning.fleet_lattice import Lattice, assign, follows_free_space, grid_lattice, lattice
from amr_planning.fleet_paths import FleetPlan
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


@pytest.mark.parametrize("solver", [plan_together, plan_lacam])
def test_two_robots_swap_ends_of_a_corridor_through_its_pocket(solver):
    graph = corridor_with_pocket()
    plan = solver(graph, [0, 4], [4, 0])
    check(plan, [0, 4], [4, 0])
    assert 5 in plan.paths[0] or 5 in plan.paths[1]  # one of them waited in the pocket
    if solver is plan_together:  # least sum of steps: 4 + 4 moves, one detour of 2 and one wait, or the like
        assert plan.cost == 11


def test_a_swap_in_a_bare_corridor_is_refused_as_impossible():
    graph = graph_of([[0, 0], [1, 0], [2, 0], [3, 0]], [(0, 1), (1, 2), (2, 3)])
    with pytest.raises(PlanningError, match="no plan exists"):
        plan_lacam(graph, [0, 3], [3, 0])


@pytest.mark.parametrize(
    "starts, goals, message",
    [
        ([0, 0], [3, 4], "share a start"),
        ([0, 1], [4, 4], "share a goal"),
        ([0, 9], [3, 4], "not on the lattice"),
        ([0], [3, 4], "1 starts but 2 goals"),
    ],
)
def test_bad_requests_are_refused_with_what_is_wrong(starts, goals, message):
    for solver in (plan_together, plan_lacam):
        with pytest.raises(PlanningError, match=message):
            solver(corridor_with_pocket(), starts, goals)


def maze_case(seed: int, robots: int = 6):
    data = with_robots(generate("perfect", seed, size=4.0), robots, seed)
    pitch = grid_pitch(data)
    costmap = Costmap(rasterize_world(world_from_dict(data), 0.025))
    return data, costmap, pitch


@pytest.mark.parametrize("seed", [0, 3])
def test_the_lattice_of_a_tree_maze_is_its_cells_joined_where_open(seed):
    data, costmap, pitch = maze_case(seed)
    graph = lattice(costmap, pitch)
    walls = np.asarray(data["walls"], dtype=float)
    extent = walls[:, [0, 2]].max() - walls[:, [0, 2]].min()
    cells = round(extent / pitch)
    assert len(graph) == cells * cells
    edges = sum(len(n) for n in graph.neighbours) // 2
    assert edges == len(graph) - 1  # a perfect maze is a tree
    assert (graph.distances(0) >= 0).all()  # connected
    # the points are the cell centres: half a pitch (less a little) from the nearest wall line
    low = walls[:, [0, 2]].min()
    offsets = (graph.points - low) / pitch - 0.5
    assert np.abs(offsets - np.round(offsets)).max() < 0.1


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


@pytest.mark.parametrize(
    "family, seed", [("rotated", 0), ("rotated", 3), ("bends", 1), ("curved", 2), ("narrowing", 0), ("thin_walls", 4)]
)
def test_where_the_grid_leaves_the_free_space_in_pieces_the_lattice_is_sampled_over_it_and_joined(family, seed):
    """A corridor at an angle to the grid (rotated mazes, bends, curves) leaves the square grid in pieces: robots
    there could not be planned (the fleet went by the traffic rules alone). The sampled lattice is one piece, its
    points in the free space, each joined to points within reach along the free space, and no free cell far
    from a point."""
    from scipy.ndimage import distance_transform_edt

    costmap = Costmap(rasterize_world(world_from_dict(generate(family, seed, size=4.0)), 0.025))
    grid = grid_lattice(costmap, 0.4)
    assert not follows_free_space(costmap, grid) and components(grid) > 1
    graph = lattice(costmap, 0.4)
    assert components(graph) == 1 and len(graph) > len(grid)
    assert not costmap.lethal_at(graph.points, costmap.inflated).any()
    gaps = np.hypot(*(graph.points[:, None, :] - graph.points[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(gaps, np.inf)
    close = np.argwhere(np.triu(gaps < 0.4 - 1e-9))  # two points within a spacing: only with a wall between
    assert not costmap.segments_free(graph.points[close[:, 0]], graph.points[close[:, 1]]).any()
    for vertex, neighbours in enumerate(graph.neighbours):
        assert neighbours and max(gaps[vertex, list(neighbours)]) < 3 * 0.4
    away = np.ones(costmap.inflated.shape, dtype=bool)
    rows, cols = costmap.grid.world_to_cell(graph.points[:, 0], graph.points[:, 1])
    away[rows, cols] = False
    assert (distance_transform_edt(away) * costmap.resolution)[~costmap.inflated].max() <= 1.5 * 0.4


def test_a_lattice_of_a_rotated_maze_carries_a_fleet_plan():
    data = with_robots(generate("rotated", 1, size=4.0), 6, 1)
    costmap = Costmap(rasterize_world(world_from_dict(data), 0.025))
    graph = lattice(costmap, 0.4)
    starts = assign(graph, costmap, [robot["start"][:2] for robot in data["robots"]])
    goals = assign(graph, costmap, [robot["goal"][:2] for robot in data["robots"]])
    plan = improve(plan_lacam(graph, starts, goals))
    check(plan, starts, goals)
    dependencies(plan)  # no cycle


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


def test_lattice_refuses_a_spacing_below_the_map_resolution():
    _, costmap, _ = maze_case(0)
    for spacing in (0.01, math.nan, -1.0):
        with pytest.raises(PlanningError, match="spacing"):
            lattice(costmap, spacing)


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


@pytest.mark.parametrize("seed", [0, 1])
def test_robots_following_the_dependencies_at_random_speeds_never_meet_and_all_arrive(seed):
    data, costmap, pitch = maze_case(seed)
    graph = lattice(costmap, pitch)
    starts = [graph.nearest(*robot["start"][:2]) for robot in data["robots"]]
    goals = [graph.nearest(*robot["goal"][:2]) for robot in data["robots"]]
    plan = improve(plan_lacam(graph, starts, goals))
    for trial in range(3):
        execute(plan, np.random.default_rng(trial))


def test_without_the_dependencies_random_speeds_make_robots_meet():
    """The check above can fail: the same execution with no dependencies puts two robots on one vertex."""
    graph = corridor_with_pocket()
    plan = plan_lacam(graph, [0, 4], [4, 0])
    none = [[[] for _ in path] for path in plan.paths]
    with pytest.raises(AssertionError, match="both on vertex|may enter"):
        for trial in range(20):
            execute(plan, np.random.default_rng(trial), none)


def test_execution_time_waits_for_the_dependencies_not_for_steps_and_counts_the_turns():
    # 0-1-2-3 in a row 1 m apart, 4 above 3; r0 drives 1 -> 2 -> 3, turns a quarter and drives to 4; r1 follows it
    # 0 -> 1 -> 2, each move once r0 has left the vertex. At 0.5 m/s (2 s a move) and 1 rad/s:
    # r0 arrives at 2 s, 4 s, 6 s + pi/2; r1 enters 1 at max(0, 2) + 2 = 4 s and 2 at max(4, 4) + 2 = 6 s.
    graph = graph_of([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1]], [(0, 1), (1, 2), (2, 3), (3, 4)])
    plan = FleetPlan(graph, ((1, 2, 3, 4), (0, 1, 2, 2)), 0)
    assert plan.makespan == 3
    assert execution_time(plan, 0.5, 1.0) == pytest.approx(6.0 + math.pi / 2)
    assert execution_time(plan, 0.5, 100.0) == pytest.approx(6.0 + math.pi / 200)
    # r1 planned to wait a step first: more lockstep steps, the same time (it waits for r0's moves, not for steps)
    waiting = FleetPlan(graph, ((1, 2, 3, 4), (0, 0, 1, 2)), 0)
    assert waiting.makespan == 3 and execution_time(waiting, 0.5, 1.0) == pytest.approx(6.0 + math.pi / 2)
    # r1 alone would be done at 4 s: the 2 s more are r0's
    assert execution_time(FleetPlan(graph, ((0, 1, 2),), 0), 0.5, 1.0) == pytest.approx(4.0)
    for speed, turn_rate in [(0.0, 1.0), (math.nan, 1.0), (0.5, -1.0), (0.5, math.inf)]:
        with pytest.raises(ValueError, match="speed and turn_rate"):
            execution_time(plan, speed, turn_rate)


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


def test_grid_pitch_is_the_cell_of_a_grid_maze_and_refuses_what_is_none():
    walls = [[0.0, 0.0, 1.5, 0.0], [0.0, 0.5, 1.0, 0.5], [1.0, 0.5, 1.0, 1.5], [0.0, 1.5, 1.5, 1.5]]
    assert grid_pitch({"walls": walls}) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="not a grid maze"):
        grid_pitch({"walls": [[0.0, 0.0, 0.02, 0.0]]})


def two_rows_costmap() -> Costmap:
    """Two corridors of two cells 0.6 m wide, one above the other, joined only at the left (x < 0.6)."""
    walls = [[0, 0, 1.2, 0], [1.2, 0, 1.2, 1.2], [1.2, 1.2, 0, 1.2], [0, 1.2, 0, 0], [0.6, 0.6, 1.2, 0.6]]
    world = world_from_dict({"name": "two_rows", "wall_thickness": 0.05, "walls": walls, "start": [0.3, 0.3, 0]})
    return Costmap(rasterize_world(world, 0.02))


def test_assign_keeps_two_robots_in_one_cell_on_their_side_of_the_wall_and_in_their_order():
    """Two robots in the bottom right cell: the second one's nearest free vertex is the cell above, beyond the wall
    (what planning each from its nearest free vertex gave: in `perfect 15` that robot drove the long way round and
    stood stuck far from the vertex it was planned from). assign gives each a vertex it reaches without that detour,
    the left one the left vertex."""
    costmap = two_rows_costmap()
    graph = lattice(costmap, 0.6)
    vertex = {
        name: graph.nearest(*centre)
        for name, centre in {"bottom_left": (0.3, 0.3), "bottom_right": (0.9, 0.3), "top_right": (0.9, 0.9)}.items()
    }
    assert np.allclose(graph.points[vertex["top_right"]], (0.9, 0.9), atol=0.05)
    right, left = (0.95, 0.25), (0.85, 0.42)
    greedy = [graph.nearest(*right)]
    greedy.append(graph.nearest(*left, taken=greedy))
    assert greedy == [vertex["bottom_right"], vertex["top_right"]]  # beyond the wall
    assert assign(graph, costmap, [right, left]) == [vertex["bottom_right"], vertex["bottom_left"]]
    assert assign(graph, costmap, [left, right]) == [vertex["bottom_left"], vertex["bottom_right"]]
    # a vertex taken (a stuck robot's) is never given; the way goes on along the lattice past it
    assert assign(graph, costmap, [left], taken=[vertex["bottom_left"]]) == [vertex["bottom_right"]]
    assert assign(graph, costmap, []) == []


def test_assign_refuses_more_points_than_vertices_and_points_that_are_not_finite():
    costmap = two_rows_costmap()
    graph = lattice(costmap, 0.6)
    with pytest.raises(PlanningError, match="no vertex left"):
        assign(graph, costmap, [(0.3, 0.3)] * (len(graph) + 1))
    with pytest.raises(PlanningError, match="finite"):
        assign(graph, costmap, [(math.nan, 0.3)])


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
