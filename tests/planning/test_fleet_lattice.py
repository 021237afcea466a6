"""The lattice a fleet is planned on (amr_planning.fleet_lattice): a tree maze's cells, the sampled lattice where
the grid leaves the free space in pieces, the spacing refused, and the start vertices (assign)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.fleet_plans import check, components, maze_case

from amr_maps.maze_families import generate, grid_pitch
from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError
from amr_planning.fleet_execution import dependencies
from amr_planning.fleet_improve import improve
from amr_planning.fleet_lacam import plan_lacam
from amr_planning.fleet_lattice import assign, follows_free_space, grid_lattice, lattice
from amr_planning.fleet_starts import with_robots


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


def test_lattice_refuses_a_spacing_below_the_map_resolution():
    _, costmap, _ = maze_case(0)
    for spacing in (0.01, math.nan, -1.0):
        with pytest.raises(PlanningError, match="spacing"):
            lattice(costmap, spacing)


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
