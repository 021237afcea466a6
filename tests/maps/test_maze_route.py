"""Routes through grid mazes as cells: the grid read back from the walls, the ideal hand tour, a trajectory's cells."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_maps.maze_families import generate
from amr_maps.maze_route import MazeGrid, NotAGridMaze, cell_route, first_difference, hand_tour


def test_the_grid_is_read_back_from_the_walls():
    # Two cells side by side, 0.5 m pitch, open to each other: an outline with no wall between them.
    world = {"walls": [[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 1.0, 0.5], [1.0, 0.5, 0.0, 0.5], [0.0, 0.5, 0.0, 0.0]]}
    grid = MazeGrid.from_world(world)
    assert (grid.n, grid.m, grid.pitch) == (2, 1, pytest.approx(0.5))
    assert grid.open_between((0, 0), (1, 0))
    world["walls"].append([0.5, 0.0, 0.5, 0.5])
    assert not MazeGrid.from_world(world).open_between((0, 0), (1, 0))


@pytest.mark.parametrize(
    "family, options",
    [
        ("perfect", {}),
        ("rotated", {"loop_fraction": 0.0}),
        ("thin_walls", {"loop_fraction": 0.0}),
        ("dead_ends", {}),
    ],
)
def test_a_tree_maze_tour_walks_every_passage_twice_and_reaches_the_goal(family, options):
    world = generate(family, 3, **options)
    grid = MazeGrid.from_world(world)
    tour = hand_tour(grid, world["start"])
    visited = set(tour)
    assert len(tour) == 2 * len(visited) - 1  # round a tree: every passage once each way
    assert tour[0] == tour[-1] == grid.cell(*world["start"][:2])
    assert grid.cell(*world["goal"][:2]) in visited  # generated goals are ones the right hand reaches


def test_left_and_right_hands_walk_the_tree_in_opposite_orders():
    world = generate("perfect", 5, size=3.0)
    grid = MazeGrid.from_world(world)
    right, left = hand_tour(grid, world["start"], "right"), hand_tour(grid, world["start"], "left")
    assert right == left[::-1]


def test_worlds_off_a_grid_are_refused():
    with pytest.raises(NotAGridMaze, match="not along a grid line"):
        MazeGrid.from_world(generate("bends", 0))


def test_a_trajectory_enters_a_cell_only_once_well_inside_it():
    grid = MazeGrid.from_world(generate("perfect", 1, size=3.0, width=0.4))
    p = grid.pitch
    ox, oy = grid.origin
    # Along row 0 through cells 0 and 1, hovering 2 cm past the line into cell 2, then back.
    xs = np.concatenate([np.linspace(0.5, 2.02, 80), np.linspace(2.02, 1.5, 30)]) * p + ox
    points = np.stack([xs, np.full(len(xs), oy + 0.5 * p)], axis=1)
    assert cell_route(grid, points) == [(0, 0), (1, 0)]
    assert cell_route(grid, points, margin=0.0) == [(0, 0), (1, 0), (2, 0), (1, 0)]
    assert cell_route(grid, [(math.nan, math.nan), *points[:1]]) == [(0, 0)]


def test_first_difference():
    tour = [(0, 0), (1, 0), (1, 1), (1, 0), (0, 0)]
    assert first_difference(tour[:3], tour) is None
    assert first_difference([(0, 0), (1, 0), (2, 0)], tour) == 2
    assert first_difference(tour + [(0, 1)], tour) == len(tour)
