"""Costmap: inflation by robot radius + margin from the exact distance transform, cost rising near walls."""

import math

import numpy as np
import pytest
from support.planning import grid, walled

from amr_planning.costmap import MIN_COST, Costmap, CostmapConfig
from amr_util.parameter_spec import ConfigError


def test_a_single_obstacle_cell_is_lethal_within_the_robot_radius_and_inflated_to_radius_plus_margin():
    data = np.zeros((101, 101), dtype=np.int8)
    data[50, 50] = 100
    config = CostmapConfig(robot_radius=0.1, safety_margin=0.05)
    costmap = Costmap(grid(data, 0.01), config)
    rows, cols = np.indices(data.shape)
    centre_distance = np.hypot(rows - 50, cols - 50) * 0.01
    # clearance = distance to the obstacle cell's edge (half a cell less than to its centre),
    # within 0.25 m of it, where the map border (0.5 m away) is further than the obstacle.
    inner = centre_distance < 0.25
    expected = np.maximum(centre_distance - 0.005, 0.0)
    assert np.allclose(costmap.clearance[inner & (centre_distance > 0)], expected[inner & (centre_distance > 0)])
    lethal_radius = centre_distance[costmap.lethal & inner].max()
    inflated_radius = centre_distance[costmap.inflated & inner].max()
    assert 0.10 <= lethal_radius + 0.005 < 0.10 + 0.01
    assert 0.15 <= inflated_radius + 0.005 < 0.15 + 0.01
    assert not costmap.inflated[50, 50 + 16] and costmap.inflated[50, 50 + 15]
    assert not costmap.lethal[50, 50 + 11] and costmap.lethal[50, 50 + 10]
    # inside the margin: passable at a steep price
    margin_cell, open_cell = costmap.cost[50, 50 + 13], costmap.cost[50, 50 + 16]
    assert np.isfinite(margin_cell) and margin_cell >= open_cell + config.margin_cost


def test_the_map_border_counts_as_an_obstacle():
    data = np.zeros((40, 40), dtype=np.int8)
    costmap = Costmap(grid(data, 0.01), CostmapConfig(robot_radius=0.05, safety_margin=0.0))
    assert costmap.lethal[0, 20] and costmap.lethal[20, 4] and not costmap.lethal[20, 20]


def test_cost_is_lowest_in_the_middle_of_a_corridor_and_infinite_when_lethal():
    data = np.full((20, 60), 100, dtype=np.int8)
    data[5:15, :] = 0  # a 0.5 m corridor along x at 0.05 m
    costmap = Costmap(grid(data), CostmapConfig(robot_radius=0.1, safety_margin=0.02, cost_weight=3.0))
    column = costmap.cost[:, 30]
    finite = np.isfinite(column)
    assert finite.sum() >= 2 and (~finite).sum() > 0
    assert column[finite].min() >= MIN_COST
    middle = np.argmin(np.where(finite, column, np.inf))
    assert middle in (9, 10)
    # symmetric about the corridor's middle, rising towards the walls
    assert np.allclose(column[5:15], column[5:15][::-1])
    assert np.all(np.diff(column[finite][: int(finite.sum()) // 2]) <= 0)


def test_unknown_cells_are_obstacles_unless_configured_free():
    data = walled(30, 30)
    data[10:20, 10:20] = -1
    assert Costmap(grid(data)).obstacle[15, 15]
    assert not Costmap(grid(data), CostmapConfig(unknown_is_obstacle=False)).obstacle[15, 15]


def test_segments_are_checked_against_lethal_cells():
    data = walled(40, 40)
    data[:30, 20] = 100  # a wall from the bottom, open at the top
    costmap = Costmap(grid(data), CostmapConfig(robot_radius=0.05, safety_margin=0.0))
    free = costmap.segments_free(np.array([[0.5, 0.5], [0.5, 1.75]]), np.array([[1.5, 0.5], [1.5, 1.75]]))
    assert free.tolist() == [False, True]


def documented_samples_free(costmap, start, end, mask) -> bool:
    """segments_free's documented sampling, point by point through lethal_at."""
    length = math.hypot(end[0] - start[0], end[1] - start[1])
    count = max(math.ceil(length / (0.25 * costmap.resolution)), 1) + 1
    points = [start + k / (count - 1) * (end - start) for k in range(count)]
    return not costmap.lethal_at(np.array(points), mask).any()


@pytest.mark.parametrize("mask", ["lethal", "inflated", "writable copy"])
def test_segments_free_samples_every_quarter_cell_as_documented_on_and_off_the_map(mask):
    data = walled(60, 50)
    data[10:40, 25] = 100
    data[30, 5:20] = 100
    costmap = Costmap(grid(data, 0.05, origin=(-1.0, 0.5)), CostmapConfig(robot_radius=0.06))  # 2.5 x 3 m
    chosen = {"lethal": None, "inflated": costmap.inflated, "writable copy": np.array(costmap.inflated)}[mask]
    rng = np.random.default_rng(3)
    starts = rng.uniform([-1.3, 0.2], [1.8, 3.8], (400, 2))
    ends = starts + rng.normal(0.0, 0.6, (400, 2)) * rng.choice([0.0, 0.05, 1.0], (400, 1))
    free = costmap.segments_free(starts, ends, chosen)
    expected = [documented_samples_free(costmap, a, b, chosen) for a, b in zip(starts, ends, strict=True)]
    assert free.tolist() == expected
    assert 0.05 < free.mean() < 0.95  # both answers are exercised


def test_a_segment_with_a_non_finite_end_is_not_free_and_mismatched_ends_are_refused():
    costmap = Costmap(grid(walled(40, 40)), CostmapConfig(robot_radius=0.05, safety_margin=0.0))
    starts = np.array([[0.5, 0.5], [math.nan, 0.5], [0.5, 0.5], [0.5, 0.5]])
    ends = np.array([[1.0, 1.0], [1.0, 1.0], [math.inf, 1.0], [0.5, 0.5]])
    assert costmap.segments_free(starts, ends).tolist() == [True, False, False, True]
    with pytest.raises(ValueError, match="3 starts but 2 ends"):
        costmap.segments_free(starts[:3], ends[:2])


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"robot_radius": 0.0}, "robot_radius"),
        ({"safety_margin": -0.01}, "safety_margin"),
        ({"cost_weight": math.nan}, "cost_weight"),
        ({"occupied_threshold": 0}, "occupied_threshold"),
    ],
)
def test_bad_configs_are_refused_by_name(kwargs, name):
    with pytest.raises(ConfigError, match=name):
        CostmapConfig(**kwargs)
