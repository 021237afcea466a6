"""Gradient smoothing: smoother paths that never enter an inflated cell, end points fixed."""

import numpy as np
import pytest
from scipy.ndimage import label
from support.planning import grid, random_blocks

from amr_planning.astar import GridAStar
from amr_planning.costmap import Costmap, CostmapConfig
from amr_planning.roadmap import Roadmap, RoadmapConfig
from amr_planning.smoothing import SmoothingConfig, densify, smooth_path
from amr_util.parameter_spec import ConfigError


def heading_changes(points: np.ndarray) -> np.ndarray:
    """Absolute heading change at each interior point of a polyline (rad)."""
    headings = np.unwrap(np.arctan2(*np.diff(points, axis=0).T[::-1]))
    return np.abs(np.diff(headings))


def turning(points: np.ndarray) -> float:
    """Total absolute heading change along a polyline (rad)."""
    return float(heading_changes(points).sum())


@pytest.mark.parametrize("seed", range(10))
def test_smoothed_paths_never_enter_inflated_cells(seed):
    rng = np.random.default_rng(100 + seed)
    costmap = Costmap(grid(random_blocks(rng, 50, 60, count=25, largest=10)), CostmapConfig(robot_radius=0.06))
    regions, _ = label(~costmap.lethal)  # 4-connected: always reachable with 8-connected moves
    largest = np.argmax(np.bincount(regions.ravel())[1:]) + 1
    free = np.argwhere(regions == largest)
    start, goal = (costmap.centre(*free[i]) for i in rng.choice(len(free), 2, replace=False))
    raw = GridAStar(costmap).plan(start, goal).points
    for config in (SmoothingConfig(), SmoothingConfig(data_weight=0.02, smooth_weight=0.5)):
        smooth = smooth_path(raw, costmap, config)
        assert np.allclose(smooth[0], raw[0]) and np.allclose(smooth[-1], raw[-1])
        assert not costmap.lethal_at(smooth).any()
        assert costmap.segments_free(smooth[:-1], smooth[1:]).all()
        clear = costmap.segments_free(raw[:-1], raw[1:], costmap.inflated)
        if clear.all():  # a path clear of the safety margin stays clear of it
            assert costmap.segments_free(smooth[:-1], smooth[1:], costmap.inflated).all()
        assert turning(smooth) <= turning(densify(raw, config.spacing)) + 1e-9


def test_a_roadmap_zigzag_is_straightened():
    data = np.zeros((40, 80), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    data[10:30, 38:42] = 100  # a pillar between start and goal: no straight line
    costmap = Costmap(grid(data))
    raw = Roadmap(costmap, RoadmapConfig(node_count=200, connection_distance=0.4, seed=2)).plan((0.3, 1.0), (3.7, 1.0))
    smooth = smooth_path(raw.points, costmap, SmoothingConfig(data_weight=0.05, smooth_weight=0.45))
    assert len(raw.points) > 3
    assert not costmap.lethal_at(smooth).any()
    sharpest = heading_changes(densify(raw.points, 0.05)).max()
    assert heading_changes(smooth).max() < 0.5 * sharpest
    assert turning(smooth) < turning(densify(raw.points, 0.05))


def test_smoothing_next_to_a_corner_keeps_the_original_points_where_it_would_collide():
    data = np.zeros((40, 40), dtype=np.int8)
    data[:20, 20:] = 100  # an L-shaped room: the path turns around the block's corner
    costmap = Costmap(grid(data), CostmapConfig(robot_radius=0.1, safety_margin=0.0, cost_weight=0.0))
    raw = GridAStar(costmap).plan((1.75, 1.25), (0.25, 0.25)).points
    hard = smooth_path(raw, costmap, SmoothingConfig(data_weight=0.01, smooth_weight=0.5))
    assert not costmap.lethal_at(hard, costmap.inflated).any()
    corner_clearance = np.hypot(hard[:, 0] - 1.0, hard[:, 1] - 1.0).min()
    assert corner_clearance >= 0.1 - 0.05  # within a cell of the inflation radius, never inside it


def test_densify_bounds_the_gaps_and_keeps_the_points():
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.12]])
    dense = densify(points, 0.05)
    assert np.hypot(*np.diff(dense, axis=0).T).max() <= 0.05 + 1e-12
    for p in points:
        assert np.isclose(np.hypot(*(dense - p).T).min(), 0.0)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"data_weight": 0.0}, "data_weight"),
        ({"smooth_weight": 0.6}, "smooth_weight"),
        ({"spacing": 0.0}, "spacing"),
        ({"max_iterations": 0}, "max_iterations"),
    ],
)
def test_bad_configs_are_refused_by_name(kwargs, name):
    with pytest.raises(ConfigError, match=name):
        SmoothingConfig(**kwargs)
