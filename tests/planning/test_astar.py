"""Grid A*: optimal against a brute-force Dijkstra, clear of inflated cells, and clear errors instead of half paths."""

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from support.planning import grid, random_blocks, walled

from amr_planning.astar import GridAStar
from amr_planning.costmap import Costmap, CostmapConfig
from amr_planning.errors import PlanningError, Reason

SMALL_ROBOT = CostmapConfig(robot_radius=0.04, safety_margin=0.01)


def brute_force_cost(costmap: Costmap, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """Dijkstra over every edge of the 8-connected graph (same move rules, written independently)."""
    rows, cols = costmap.shape
    cost, res = costmap.cost, costmap.resolution
    sources, targets, weights = [], [], []
    for r in range(rows):
        for c in range(cols):
            if not np.isfinite(cost[r, c]):
                continue
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if (dr, dc) == (0, 0) or not (0 <= rr < rows and 0 <= cc < cols) or not np.isfinite(cost[rr, cc]):
                        continue
                    if dr and dc and not (np.isfinite(cost[r + dr, c]) and np.isfinite(cost[r, c + dc])):
                        continue  # no squeezing diagonally between two blocked cells
                    sources.append(r * cols + c)
                    targets.append(rr * cols + cc)
                    weights.append(math.hypot(dr, dc) * res * 0.5 * (cost[r, c] + cost[rr, cc]))
    graph = coo_matrix((weights, (sources, targets)), shape=(rows * cols, rows * cols)).tocsr()
    distances = dijkstra(graph, indices=start[0] * cols + start[1])
    return float(distances[goal[0] * cols + goal[1]])


@pytest.mark.parametrize("seed", range(12))
def test_astar_cost_equals_brute_force_dijkstra_on_random_grids(seed):
    rng = np.random.default_rng(seed)
    costmap = Costmap(grid(random_blocks(rng, 24, 30, count=14)), SMALL_ROBOT)
    free = np.argwhere(~costmap.lethal)
    planner = GridAStar(costmap)
    for _ in range(4):
        start, goal = (tuple(map(int, free[i])) for i in rng.choice(len(free), 2, replace=False))
        expected = brute_force_cost(costmap, start, goal)
        start_xy, goal_xy = costmap.centre(*start), costmap.centre(*goal)
        if math.isinf(expected):
            with pytest.raises(PlanningError) as error:
                planner.plan(start_xy, goal_xy)
            assert error.value.reason is Reason.UNREACHABLE
            continue
        path = planner.plan(start_xy, goal_xy)
        assert path.cost == pytest.approx(expected, rel=1e-9)
        assert np.allclose(path.points[0], start_xy) and np.allclose(path.points[-1], goal_xy)
        assert not costmap.lethal_at(path.points).any()
        assert costmap.segments_free(path.points[:-1], path.points[1:]).all()


def test_the_path_keeps_to_the_middle_of_a_corridor():
    data = np.full((14, 80), 100, dtype=np.int8)
    data[2:12, 1:79] = 0  # 0.5 m wide, y in [0.1, 0.6]: the rising cost bands of both walls overlap
    costmap = Costmap(grid(data))
    path = GridAStar(costmap).plan((0.3, 0.3), (3.7, 0.4)).points
    middle = path[(path[:, 0] > 1.0) & (path[:, 0] < 3.0)]
    assert np.abs(middle[:, 1] - 0.35).max() <= 0.025 + 1e-9  # one of the two middle rows
    shortest = GridAStar(Costmap(grid(data), CostmapConfig(cost_weight=0.0))).plan((0.3, 0.3), (3.7, 0.4))
    assert shortest.length <= GridAStar(costmap).plan((0.3, 0.3), (3.7, 0.4)).length


def test_a_goal_behind_a_closed_wall_is_unreachable_with_a_message():
    data = walled(30, 30)
    data[:, 15] = 100
    with pytest.raises(PlanningError, match="no collision-free path") as error:
        GridAStar(Costmap(grid(data), SMALL_ROBOT)).plan((0.3, 0.7), (1.2, 0.7))
    assert error.value.reason is Reason.UNREACHABLE


def test_a_passage_inside_the_margin_is_crossed_through_its_middle_only_when_no_clear_way_exists():
    data = walled(40, 60)  # 2 x 3 m
    data[:, 29:32] = 100  # a 0.15 m thick wall across
    data[5:10, 29:32] = 0  # door rows 5-9: 0.25 m, the robot fits (0.21 m), its 0.03 m margin does not
    config = CostmapConfig(safety_margin=0.03)
    costmap = Costmap(grid(data), config)
    door = costmap.inflated[5:10, 30]
    assert door.all() and not costmap.lethal[7, 30]
    path = GridAStar(costmap).plan((0.5, 1.5), (2.5, 1.5)).points
    through = path[np.argmin(np.abs(path[:, 0] - 1.525))]
    assert abs(through[1] - 0.375) <= 0.025 + 1e-9  # the door's middle row
    data = data.copy()  # OccupancyGrid froze the array it was given
    data[30:38, 29:32] = 0  # a 0.4 m door further on: the margin is kept there
    path = GridAStar(Costmap(grid(data), config)).plan((0.5, 1.5), (2.5, 1.5)).points
    assert path[np.argmin(np.abs(path[:, 0] - 1.525)), 1] > 1.4


def test_a_gap_narrower_than_the_robot_is_closed():
    data = walled(30, 30)
    data[:, 15] = 100
    data[14:16, 15] = 0  # 0.1 m gap, robot 0.21 m
    with pytest.raises(PlanningError) as error:
        GridAStar(Costmap(grid(data))).plan((0.3, 0.7), (1.2, 0.7))
    assert error.value.reason is Reason.UNREACHABLE


@pytest.mark.parametrize(
    "start, goal, reason, words",
    [
        ((0.7, 0.7), (5.0, 0.7), Reason.OUTSIDE_MAP, "goal .* off the map"),
        ((-1.0, 0.7), (0.7, 0.7), Reason.OUTSIDE_MAP, "start .* off the map"),
        ((0.7, 0.7), (math.nan, 0.7), Reason.INVALID, "goal .* finite"),
        ((0.7, math.inf), (0.7, 0.7), Reason.INVALID, "start .* finite"),
        ((0.7, 0.7), (0.76, 0.76), Reason.GOAL_BLOCKED, "occupied cell"),
        ((0.7, 0.7), (1.21, 0.76), Reason.GOAL_BLOCKED, "unknown \\(never seen\\) cell"),
        ((0.76, 0.76), (0.3, 0.3), Reason.START_BLOCKED, "occupied cell"),
        ((0.7, 0.7), ("a", 1), Reason.INVALID, "two numbers"),
        ((0.7, 0.7), (1.0,), Reason.INVALID, "two numbers"),
    ],
)
def test_bad_requests_raise_a_planning_error_naming_the_problem(start, goal, reason, words):
    data = walled(30, 30)
    data[15, 15] = 100  # cell centre (0.775, 0.775)
    data[15, 24] = -1  # cell centre (1.225, 0.775): never seen, an obstacle by default
    with pytest.raises(PlanningError, match=words) as error:
        GridAStar(Costmap(grid(data), SMALL_ROBOT)).plan(start, goal)
    assert error.value.reason is reason


def test_a_start_in_the_inflated_band_escapes_to_the_nearest_free_cell():
    data = walled(30, 30)
    costmap = Costmap(grid(data))  # robot radius 0.105 m: cells that close to the walls are lethal
    start = (0.12, 0.75)  # 0.07 m from the west wall's face: the robot fits, the margin does not
    assert costmap.lethal_at(np.array([start]))[0]
    path = GridAStar(costmap).plan(start, (0.75, 0.75)).points
    assert np.allclose(path[0], start)
    assert not costmap.lethal_at(path[1:]).any()
    assert costmap.segments_free(path[1:-1], path[2:]).all()


def test_a_start_deep_in_the_band_beyond_snap_distance_is_refused():
    data = walled(30, 30)
    data[:, 3:27] = 100
    data[:, 14:16] = 0  # a 0.1 m slot: no cell has the clearance, none within snap distance
    with pytest.raises(PlanningError, match="nearest cell clear enough|no cell where the robot fits") as error:
        GridAStar(Costmap(grid(data))).plan((0.75, 0.5), (0.75, 1.0))
    assert error.value.reason is Reason.START_BLOCKED
