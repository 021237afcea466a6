"""Frontier detection, reach and choice (amr_mapping.frontiers) and the explorer finishing small worlds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support.mapping import reveal, unknown_like

from amr_mapping.explorer import DONE, EXPLORING, WAITING, Explorer, ExplorerConfig
from amr_mapping.frontiers import (
    FrontierConfig,
    best_frontier,
    detect_frontiers,
    frontier_mask,
    path_distances,
    reach_frontiers,
    safe_cells,
)
from amr_maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world, resolve_world_path
from amr_util.parameter_spec import ConfigError

RES = 0.05


def room(width: int = 40, height: int = 30) -> np.ndarray:
    """A walled room of free cells (rows x cols = height x width) with everything outside unknown."""
    data = np.full((height, width), UNKNOWN, dtype=np.int8)
    data[1:-1, 1:-1] = 0
    data[0, :] = data[-1, :] = OCCUPIED
    data[:, 0] = data[:, -1] = OCCUPIED
    return data


def grid(data: np.ndarray) -> OccupancyGrid:
    return OccupancyGrid(data, RES)


def test_frontier_cells_are_free_cells_beside_unknown_ones_grouped_8_connected():
    data = room()
    data[10:20, 39] = UNKNOWN  # an opening in the east wall: free cells at col 38 border it
    data[1:4, 1:4] = UNKNOWN  # an unseen corner inside
    mask = frontier_mask(grid(data))
    assert mask[10:20, 38].all() and not mask[10:20, 37].any()
    assert not mask[0].any() and not mask[:, 0].any()  # walls are never frontier cells
    frontiers = detect_frontiers(grid(data), min_frontier_size=0.0)
    assert sorted(f.size for f in frontiers) == [6, 10]  # the corner's L (3 + 3, joined diagonally) and the opening
    opening = next(f for f in frontiers if f.size == 10)
    x, y = grid(data).cell_to_world(14.5, 38)
    assert opening.centroid == pytest.approx((float(x), float(y)))
    assert opening.length == pytest.approx(10 * RES)
    assert [f.size for f in detect_frontiers(grid(data), min_frontier_size=0.4)] == [10]  # 6 cells = 0.3 m


def test_a_fully_known_map_has_no_frontier_and_an_empty_one_none_either():
    assert detect_frontiers(grid(np.where(room() == UNKNOWN, OCCUPIED, room()).astype(np.int8))) == []
    assert detect_frontiers(grid(np.full((5, 5), UNKNOWN, dtype=np.int8))) == []


def test_path_distances_are_8_connected_lengths_over_safe_cells():
    safe = np.ones((5, 5), dtype=bool)
    safe[1:4, 2] = False  # a wall with gaps at rows 0 and 4
    distances = path_distances(safe, (2, 0), 1.0)
    assert distances[2, 0] == 0.0
    assert distances[2, 1] == 1.0
    # (2, 0) -> (1, 1) -> (0, 1) -> (0, 2): not (1, 1) -> (0, 2), which cuts the wall's corner (1, 2)
    assert distances[0, 2] == pytest.approx(math.sqrt(2) + 2)
    assert math.isinf(distances[2, 2])
    assert distances[2, 4] == pytest.approx(2 * math.sqrt(2) + 4)  # round the wall through a gap


def test_path_distances_never_cut_a_corner_as_the_planner_never_does():
    """Cells touching only at their corners are no way: amr_planning's grid A* takes a diagonal step only when both
    cells it squeezes between are free, and a frontier reached through such a chain was planned to in vain (NO_PATH,
    blacklisted: perfect mazes were 'done' at 8 s with 3 % known)."""
    safe = np.eye(4, dtype=bool)  # a diagonal chain of single cells
    distances = path_distances(safe, (0, 0), 1.0)
    assert np.isinf(distances[1, 1]) and np.isinf(distances[3, 3])
    safe[0, 1] = safe[1, 2] = safe[2, 3] = True  # a staircase: one of each diagonal's corner cells free
    distances = path_distances(safe, (0, 0), 1.0)
    assert distances[3, 3] == pytest.approx(6.0)  # 6 steps of one cell: a diagonal needs both corners free
    safe[1, 0] = True
    assert path_distances(safe, (0, 0), 1.0)[1, 1] == pytest.approx(math.sqrt(2))  # both free: the diagonal


def test_safe_cells_keep_the_robot_radius_from_walls_and_unknown():
    safe = safe_cells(grid(room()), robot_radius=0.1)
    # clearance of row r from the wall row 0: (r - 0) * 0.05 - 0.025 >= 0.1 -> r >= 2.5
    assert not safe[2, 20] and safe[3, 20]
    assert not safe[1:3].any()


def test_the_nearest_long_frontier_wins_and_a_blacklisted_or_unreachable_one_never():
    data = room(60, 30)
    data[5:25, 59] = UNKNOWN  # a long opening far east
    data[12:16, 0] = UNKNOWN  # a short one near the robot, west
    walled = grid(data)
    config = FrontierConfig(min_frontier_size=0.1)
    robot = walled.cell_to_world(14, 8)
    frontiers = reach_frontiers(walled, detect_frontiers(walled, 0.1), robot, config)
    assert all(f.reachable for f in frontiers)
    east = next(i for i, f in enumerate(frontiers) if f.size == 20)
    west = 1 - east
    # cost = 3 * distance - length: west ~ 3 * 0.2 - 0.2, east ~ 3 * 2.5 - 1.0
    assert best_frontier(frontiers) == west
    assert frontiers[west].cost == pytest.approx(3 * frontiers[west].distance - 0.2)
    greedy = FrontierConfig(min_frontier_size=0.1, potential_scale=0.1, gain_scale=1.0)
    assert best_frontier(reach_frontiers(walled, frontiers, robot, greedy)) == east  # length weighs more
    banned = reach_frontiers(walled, frontiers, robot, config, blacklist=[frontiers[west].goal])
    assert banned[west].blacklisted and best_frontier(banned) == east
    # a wall cuts the east opening off: only the west one is reachable
    data = np.array(data)
    data[:, 40] = OCCUPIED
    cut = grid(data)
    frontiers = reach_frontiers(cut, detect_frontiers(cut, 0.1), robot, config)
    assert sorted(f.reachable for f in frontiers) == [False, True]
    banned = reach_frontiers(cut, frontiers, robot, config, blacklist=[next(f.goal for f in frontiers if f.reachable)])
    assert best_frontier(banned) == -1


def test_goals_are_safe_reachable_cells_beside_their_frontier():
    data = room(60, 30)
    data[5:25, 59] = UNKNOWN
    walled = grid(data)
    config = FrontierConfig()
    robot = walled.cell_to_world(14, 8)
    (frontier,) = reach_frontiers(walled, detect_frontiers(walled), robot, config)
    safe = safe_cells(walled, config.robot_radius)
    row, col = walled.world_to_cell(*frontier.goal)
    assert safe[row, col]
    gap = np.hypot(*(np.array(frontier.goal) - np.array(frontier.centroid)))
    assert gap <= config.approach_distance
    assert frontier.distance == pytest.approx(frontier.goal[0] - robot[0], rel=0.15)


def test_config_limits_name_the_key():
    with pytest.raises(ConfigError, match="min_frontier_size"):
        FrontierConfig(min_frontier_size=-1.0)
    with pytest.raises(ConfigError, match="goal_timeout"):
        ExplorerConfig(goal_timeout=0.0)


# -- the explorer -------------------------------------------------------------------------------


def explore(world_name: str, resolution: float = 0.025, max_goals: int = 60):
    """Teleport the robot to every goal the explorer chooses, revealing the true grid by ray casting there."""
    world = load_world(resolve_world_path(world_name))
    truth = rasterize_world(world, resolution)
    known = unknown_like(truth)
    explorer = Explorer(ExplorerConfig())
    pose = (world.start.x, world.start.y, world.start.theta)
    reveal(truth, known, pose[0], pose[1])
    goals = []
    for step in range(max_goals):
        result = explorer.update(OccupancyGrid(known.copy(), truth.resolution, truth.origin), pose, float(step))
        if result.state == DONE:
            return truth, known, goals, explorer
        assert result.state == EXPLORING and result.new_goal and result.goal is not None
        goals.append(result.goal)
        pose = (*result.goal, 0.0)
        reveal(truth, known, pose[0], pose[1])
        explorer.reached()
    raise AssertionError(f"{world_name}: not done after {max_goals} goals")


@pytest.mark.parametrize("world_name", ["inner_maze.yaml", "open_room.yaml"])
def test_the_explorer_finishes_a_world_having_seen_its_free_space(world_name):
    truth, known, goals, explorer = explore(world_name)
    free = truth.data == 0
    seen = (known == 0) & free
    # the free space the robot's disc reaches from the start is what there is to see (more: the walls' other sides)
    start = load_world(resolve_world_path(world_name)).start
    start_cell = tuple(int(v) for v in truth.world_to_cell(start.x, start.y))
    reach = np.isfinite(path_distances(safe_cells(truth, 0.105), start_cell, truth.resolution))
    assert seen[reach].mean() > 0.99, (world_name, seen[reach].mean(), len(goals))
    assert seen.sum() > 0.95 * free[reach].sum()
    assert len(goals) >= 1 and explorer.state == DONE


def test_the_explorer_waits_without_a_map_keeps_its_goal_on_the_way_and_gives_failed_goals_up():
    data = room(60, 30)
    data[5:25, 59] = UNKNOWN
    data[12:16, 0] = UNKNOWN
    walled = grid(data)
    explorer = Explorer(ExplorerConfig(goal_timeout=10.0))
    assert explorer.update(None, (0.0, 0.0, 0.0), 0.0).state == WAITING
    robot = (*walled.cell_to_world(14, 8), 0.0)
    first = explorer.update(walled, robot, 0.0)
    assert first.new_goal and first.state == EXPLORING
    again = explorer.update(walled, robot, 1.0)  # the frontier is still there: the same goal, not new
    assert again.goal == first.goal and not again.new_goal
    explorer.failed("no path")
    second = explorer.update(walled, robot, 2.0)
    assert second.new_goal and second.goal != first.goal
    third = explorer.update(walled, robot, 13.0)  # more than goal_timeout after it was chosen: given up
    assert third.state == DONE and len(explorer.blacklist) == 2
    assert "goal_timeout" in " ".join(explorer.take_events())
