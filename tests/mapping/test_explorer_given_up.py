"""What the explorer gives up (amr_mapping.explorer, amr_mapping.frontiers): a reached goal's frontier by its cells,
a failed goal by its point."""

from __future__ import annotations

import math

import numpy as np

from amr_mapping.explorer import DONE, EXPLORING, Explorer, ExplorerConfig
from amr_mapping.frontiers import FrontierConfig, detect_frontiers, frontier_points, reach_frontiers
from amr_maps.occupancy_grid import OCCUPIED, UNKNOWN, OccupancyGrid

RES = 0.05


def walled(opening: slice) -> OccupancyGrid:
    """A walled room of 30 x 40 cells whose east wall (col 39) is unknown along `opening`: the frontier is the free
    cells of col 38 there."""
    data = np.zeros((30, 40), dtype=np.int8)
    data[0, :] = data[-1, :] = OCCUPIED
    data[:, 0] = data[:, -1] = OCCUPIED
    data[opening, 39] = UNKNOWN
    return OccupancyGrid(data, RES)


ROBOT = (*walled(slice(12, 17)).cell_to_world(14, 8), 0.0)


def reached_once(explorer: Explorer) -> tuple[float, float]:
    """The explorer chooses the opening of rows 12-16 and the robot reaches its goal."""
    step = explorer.update(walled(slice(12, 17)), ROBOT, 0.0)
    assert step.state == EXPLORING and step.new_goal
    explorer.reached()
    return step.goal


def test_a_reached_frontier_that_stays_is_given_up_even_a_cell_off():
    for opening in (slice(12, 17), slice(13, 18)):  # the same cells; one cell off (the map's noise)
        explorer = Explorer(ExplorerConfig())
        reached_once(explorer)
        step = explorer.update(walled(opening), ROBOT, 1.0)  # (at the goal, its footprint would clear the opening)
        assert step.state == DONE, (opening, step.reason)
        assert len(explorer.given_up) == 1 and explorer.blacklist == [] and explorer.given_up_count == 1
        assert "1 frontiers given up" in step.reason


def test_a_frontier_grown_mostly_of_new_cells_is_chosen_though_its_goal_is_the_one_reached():
    """The opening seen wider from the goal (rows 4-25: 22 cells, 7 of them within a cell of the 5 given up): another
    frontier, whose goal lies where the reached one did. A goal point given up ruled it out (rotated maze seed 0 was
    done with half of it unknown)."""
    explorer = Explorer(ExplorerConfig())
    goal = reached_once(explorer)
    step = explorer.update(walled(slice(4, 26)), ROBOT, 1.0)
    assert step.state == EXPLORING and step.new_goal, step.reason
    assert math.dist(step.goal, goal) <= explorer.config.blacklist_radius  # a point given up would rule it out
    assert step.frontiers[step.chosen].size == 22


def test_a_failed_goal_is_given_up_as_a_point_whatever_its_frontier_becomes():
    explorer = Explorer(ExplorerConfig())
    first = explorer.update(walled(slice(12, 17)), ROBOT, 0.0)
    explorer.failed("no path")
    assert explorer.blacklist == [first.goal] and explorer.given_up == []
    step = explorer.update(walled(slice(4, 26)), ROBOT, 1.0)
    assert step.state == DONE, step.reason  # the wider opening's goal is the same point


def test_reach_frontiers_marks_the_frontiers_mostly_of_given_up_cells_whose_goal_is_the_one_reached():
    config = FrontierConfig()
    small = walled(slice(12, 17))
    robot = ROBOT[:2]
    [frontier] = reach_frontiers(small, detect_frontiers(small, config.min_frontier_size), robot, config)
    points = frontier_points(small, frontier)
    assert points.shape == (5, 2)
    for opening, banned in (
        (slice(12, 17), True),
        (slice(14, 19), True),
        (slice(16, 21), False),
        (slice(4, 26), False),
    ):
        # 5 of 5 cells within a cell; 4 of 5 (rows 14-18 against 12-16: 14-17); 2 of 5 (16, 17); 7 of 22
        grid = walled(opening)
        found = detect_frontiers(grid, config.min_frontier_size)
        [reached] = reach_frontiers(grid, found, robot, config, (), [(frontier.goal, points)])
        assert reached.reachable and reached.blacklisted == banned, opening
        assert math.isinf(reached.cost) == banned
        assert math.dist(reached.goal, frontier.goal) <= config.blacklist_radius
        # the same frontier given up from a goal elsewhere (beyond blacklist_radius): tried from here
        elsewhere = (frontier.goal[0] - 2.0 * config.blacklist_radius, frontier.goal[1])
        [again] = reach_frontiers(grid, found, robot, config, (), [(elsewhere, points)])
        assert again.reachable and not again.blacklisted, opening


def test_a_goal_is_kept_while_the_robot_gets_closer_and_given_up_once_it_stops_getting_closer():
    """goal_timeout counts from the last progress (explore_lite's progress_timeout), not from the choice: a goal
    far away takes longer than the timeout to reach."""
    explorer = Explorer(ExplorerConfig(goal_timeout=10.0))
    room = walled(slice(12, 17))
    first = explorer.update(room, ROBOT, 0.0)
    for k, col in enumerate(range(9, 25)):  # a cell nearer every 8 s: 128 s in all
        step = explorer.update(room, (*room.cell_to_world(14, col), 0.0), 8.0 * (k + 1))
        assert step.goal == first.goal and not step.new_goal and step.state == EXPLORING, (col, step.reason)
    stalled = (*room.cell_to_world(14, 24), 0.0)
    assert explorer.update(room, stalled, 8.0 * 16 + 9.0).goal == first.goal  # 9 s without progress: kept
    step = explorer.update(room, stalled, 8.0 * 16 + 11.0)  # 11 s: given up (as a point: nothing else to explore)
    assert step.state == DONE and explorer.blacklist == [first.goal]
    assert "no progress within goal_timeout" in " ".join(explorer.take_events())
