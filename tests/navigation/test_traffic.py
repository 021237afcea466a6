"""Traffic rules among robots (amr_navigation.traffic): the speed rule, what counts as in the way, the costmap
with marks, the path follower's speed limit, resuming and backing off. Whole runs in the simulator's fleet (a box
not on the map, two robots face to face in a corridor one robot wide): tests/evaluation/test_fleet_traffic_runs.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_control.path_follower import PathFollower, State
from amr_maps.occupancy_grid import OccupancyGrid
from amr_navigation.traffic import TrafficConfig
from amr_navigation.traffic_geometry import free_travel, obstacle_speed, path_ahead, place_aside, unmapped
from amr_planning.costmap import Costmap
from amr_planning.planner import Planner
from amr_util.parameter_spec import ConfigError
from amr_util.scan import ScanData


def open_grid(rows: int = 60, cols: int = 100, resolution: float = 0.025) -> OccupancyGrid:
    data = np.zeros((rows, cols), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyGrid(data, resolution)


def test_speed_rule_stops_within_the_stop_distance_and_ramps_to_full_speed():
    assert obstacle_speed(0.05, 0.1, 0.5, 0.2) == 0.0
    assert obstacle_speed(0.1, 0.1, 0.5, 0.2) == 0.0
    assert obstacle_speed(0.3, 0.1, 0.5, 0.2) == pytest.approx(0.1)
    assert obstacle_speed(0.5, 0.1, 0.5, 0.2) == 0.2
    assert obstacle_speed(math.inf, 0.1, 0.5, 0.2) == 0.2
    assert obstacle_speed(math.nan, 0.1, 0.5, 0.2) == 0.0


def test_config_refuses_a_slow_distance_below_the_stop_distance_and_a_yield_clearance_within_the_path_clearance():
    with pytest.raises(ConfigError, match="slow_distance"):
        TrafficConfig(stop_distance=0.5, slow_distance=0.4)
    with pytest.raises(ConfigError, match="yield_clearance"):
        TrafficConfig(path_clearance=0.1, yield_clearance=0.05)


def test_free_travel_is_the_arc_to_the_first_disc_touching_enough_returns():
    stretch = path_ahead(np.array([[0.0, 0.0], [2.0, 0.0]]), 0.0, 0.0, 1.5)
    assert stretch[0] == pytest.approx([0.0, 0.0]) and stretch[-1] == pytest.approx([1.5, 0.0])
    wall = np.array([[1.0, y] for y in (-0.05, 0.0, 0.05)])
    assert free_travel(stretch, wall, 0.15, 3) == pytest.approx(0.85, abs=0.03)
    assert free_travel(stretch, wall[:2], 0.15, 3) == math.inf  # fewer returns than min_returns
    beside = wall + [0.0, 0.5]
    assert free_travel(stretch, beside, 0.15, 3) == math.inf  # off the path


def test_unmapped_returns_are_those_away_from_the_map():
    costmap = Costmap(open_grid())
    points = np.array([[0.01, 0.5], [1.2, 0.7], [1.2, 0.03], [50.0, 50.0]])
    assert unmapped(costmap, points, 0.08).tolist() == [False, True, False, False]


def test_costmap_with_obstacles_marks_a_copy_and_the_planner_goes_around():
    grid = open_grid(60, 120)
    planner = Planner(grid)
    straight = planner.plan((0.4, 0.75), (2.6, 0.75))
    marked = planner.with_obstacles(np.array([[1.5, 0.75]]), 0.1)
    assert marked.costmap.lethal.sum() > planner.costmap.lethal.sum()
    assert not planner.costmap.obstacle[planner.costmap.cell(1.5, 0.75)]  # the original is unchanged
    around = marked.plan((0.4, 0.75), (2.6, 0.75))
    assert np.abs(straight[:, 1] - 0.75).max() < 0.03
    assert np.hypot(around[:, 0] - 1.5, around[:, 1] - 0.75).min() > 0.1 + 0.105


def test_place_aside_is_the_nearest_cell_clear_of_the_avoided_path():
    costmap = Costmap(open_grid(60, 120))
    avoid = np.stack([np.linspace(0.2, 2.8, 60), np.full(60, 0.75)], axis=1)
    spot = place_aside(costmap, (1.5, 0.75), avoid, 0.36, 3.0)
    assert spot is not None and abs(spot[1] - 0.75) >= 0.36 and abs(spot[0] - 1.5) < 0.05
    assert place_aside(costmap, (1.5, 0.75), avoid, 2.0, 3.0) is None  # the room is not that wide


def test_path_follower_speed_limit_caps_and_zero_waits():
    scan = ScanData(np.full(240, np.inf), 0.0, 2 * math.pi / 240, 0.12, 3.5)
    path = np.array([[0.0, 0.0], [2.0, 0.0]])
    free, limited, stopped = PathFollower(), PathFollower(), PathFollower()
    for follower in (free, limited, stopped):
        follower.set_path(path)
    v_free = free.compute(0.0, 0.0, 0.0, scan).v
    assert limited.compute(0.0, 0.0, 0.0, scan, speed_limit=0.05).v == pytest.approx(0.05)
    held = stopped.compute(0.0, 0.0, 0.0, scan, speed_limit=0.0)
    assert v_free > 0.05 and (held.v, held.w) == (0.0, 0.0) and held.state is State.WAITING
    assert stopped.compute(0.0, 0.0, 0.0, scan).v == pytest.approx(v_free)  # the limit lifted: on it goes


def face_scan(distance: float, lidar_x: float = -0.032) -> ScanData:
    """A flat face across the robot's heading `distance` m ahead of its centre, seen over +-10 degrees."""
    angles = np.radians(np.arange(360) - 180.0)
    ranges = np.full(360, np.inf)
    ahead = np.abs(angles) <= np.radians(10.0)
    ranges[ahead] = (distance - lidar_x) / np.cos(angles[ahead])
    return ScanData(ranges, float(angles[0]), float(np.radians(1.0)), 0.12, 3.5)


def test_a_stopped_robot_moves_on_only_once_the_way_is_clear_by_a_margin():
    from amr_navigation.traffic import RESUME_MARGIN, Traffic
    from amr_navigation.traffic_board import TrafficBoard

    costmap = Costmap(open_grid())
    path = np.array([[1.0, 0.75], [2.4, 0.75]])
    pose = (1.0, 0.75, 0.0)
    config = TrafficConfig()
    near, beyond, clear = 0.22, 0.28, 0.7  # free travel 0.10 (< stop_distance 0.12), 0.15, 0.575 (25 mm steps)
    fresh = Traffic("a", 0, TrafficBoard(), config)
    assert fresh.advise(pose, face_scan(beyond), path, costmap, 0.2, 0.0).speed_limit > 0.0  # not stopped: creeps
    rules = Traffic("b", 0, TrafficBoard(), config)
    stamps = iter(np.arange(0.0, 10.0, 0.05))
    limits = []
    for distance in (near, beyond) * 5:  # range noise and the estimate's jitter around the stop distance
        limits.append(rules.advise(pose, face_scan(distance), path, costmap, 0.2, next(stamps)).speed_limit)
    assert limits == [0.0] * 10 and rules.counters.stops == 1
    assert config.stop_distance + RESUME_MARGIN < 0.5
    assert rules.advise(pose, face_scan(clear), path, costmap, 0.2, next(stamps)).speed_limit is None


def dense(points) -> np.ndarray:
    """A path through `points` resampled every 5 cm, as robots post theirs."""
    return path_ahead(np.array(points, dtype=float), points[0][0], points[0][1], math.inf, spacing=0.05)


def empty_scan() -> ScanData:
    return ScanData(np.full(360, np.inf), -math.pi, float(np.radians(1.0)), 0.12, 3.5)


def test_the_last_of_a_knot_of_three_gives_way_to_the_robot_it_blocks():
    """Rule 7: a, b and c each blocked by the next (a by b, b by c, c by a), a cycle the pairwise rule (rule 3) never
    resolves: the lowest-priority robot of the cycle goes aside, off the path of the one it blocks (c); the others
    do not."""
    from amr_navigation.traffic import Traffic
    from amr_navigation.traffic_board import TrafficBoard, TrafficPost

    costmap = Costmap(open_grid(60, 160))
    path = np.array([[1.5, 0.75], [3.6, 0.75]])
    pose = (1.5, 0.75, 0.0)
    c_path = dense([[1.5, 1.1], [1.5, 0.3]])

    def knot(priority: int) -> tuple[Traffic, object]:
        board = TrafficBoard()
        board.post(
            TrafficPost("b", 1 if priority != 1 else 0, (1.8, 0.75, math.pi), dense([[1.8, 0.75], [1.8, 1.3]]), "c")
        )
        board.post(TrafficPost("c", 2 if priority != 2 else 0, (1.5, 1.1, -math.pi / 2), c_path, "a"))
        rules = Traffic("a", priority, board)
        return rules, rules.advise(pose, empty_scan(), path, costmap, 0.2, 0.0)

    rules, advice = knot(3)  # a is the last of the knot
    assert advice.detour is not None and rules.counters.yields == 1, advice
    assert any("giving way to c" in event for event in advice.events), advice.events
    assert any("the last of a knot of 3 (a, b, c" in event for event in advice.events), advice.events
    spot = advice.detour[-1]
    assert np.hypot(spot[0] - 1.5, spot[1] - c_path[:, 1]).min() >= 2 * 0.105 + 0.15 - 0.03
    for first in (0, 1):  # a outranks someone in the knot: not a's turn
        rules, advice = knot(first)
        assert advice.detour is None and rules.counters.yields == 0, advice


def backed_off(rules, pose, scan: ScanData, path: np.ndarray, costmap: Costmap, timeout: float):
    """Advise `rules` every 0.1 s with the same scan until it hands out a detour: (stamp, advice), asserting that
    it stood still until then, that it backed off no sooner than `timeout` and that it said so."""
    for stamp in np.arange(0.0, timeout + 0.5, 0.1):
        advice = rules.advise(pose, scan, path, costmap, 0.2, float(stamp))
        if advice.detour is not None:
            assert stamp >= timeout, stamp
            assert any("backing off" in event for event in advice.events), advice.events
            return float(stamp), advice
        assert advice.speed_limit == 0.0 or advice.replan_around is not None
    raise AssertionError(f"no backing off within {timeout + 0.5:g} s")


def test_a_robot_stopped_by_something_no_robot_on_the_board_explains_backs_off_and_comes_back():
    """Rule 2b: stopped for yield_timeout by returns not on the map that no posted robot explains (a robot whose filter
    is not sure where it is posts no position), with no way around, the robot backs off to a place mark_range from
    them, waits there for yield_timeout, then plans to its goal again. A robot on the board standing there is left to
    the right-of-way rules instead."""
    from amr_navigation.traffic import Phase, Traffic
    from amr_navigation.traffic_board import TrafficBoard, TrafficPost

    costmap = Costmap(open_grid(60, 160))
    config = TrafficConfig(yield_timeout=10.0)
    path = np.array([[2.0, 0.75], [3.6, 0.75]])
    pose = (2.0, 0.75, 0.0)
    rules = Traffic("a", 0, TrafficBoard(), config)
    stamp, advice = backed_off(rules, pose, face_scan(0.22), path, costmap, config.yield_timeout)
    spot = advice.detour[-1]
    assert math.hypot(spot[0] - 2.2, spot[1] - 0.75) >= config.mark_range - 0.03, spot
    assert rules.phase is Phase.YIELD and rules.counters.yields == 1
    rules.arrived(stamp + 5.0)
    there = (float(spot[0]), float(spot[1]), 0.0)
    assert rules.advise(there, empty_scan(), advice.detour, costmap, 0.2, stamp + 6.0).hold  # waits there
    again = rules.advise(there, empty_scan(), advice.detour, costmap, 0.2, stamp + 10.5)
    assert again.replan and rules.phase is Phase.GO, again.events

    board = TrafficBoard()  # the same returns, but a robot on the board stands there: no backing off
    board.post(TrafficPost("b", 1, (2.33, 0.75, math.pi), None, "", (), True))
    posted = Traffic("a", 0, board, config)
    for stamp in np.arange(0.0, 12.0, 0.1):
        assert posted.advise(pose, face_scan(0.22), path, costmap, 0.2, float(stamp)).detour is None


def test_in_a_dead_end_shorter_than_mark_range_a_robot_backs_off_as_far_as_it_goes():
    """Rule 2b where no place lies mark_range from what stops it (a dead end 1 m deep) and it stands closer than two
    radii to it (a robot not sure where it is, 0.19 m ahead): it backs off to the dead end's far end. Before, the
    returns were marked as robot-sized discs, the robot's own cell lay inside them, and no place was ever found
    (fleet `perfect 15`: two robots boxed an unlocalized one in a corridor for 150 s)."""
    from amr_navigation.traffic import Phase, Traffic
    from amr_navigation.traffic_board import TrafficBoard
    from amr_navigation.traffic_geometry import farthest_place

    costmap = Costmap(open_grid(18, 60))  # a corridor 0.4 m wide, 1.5 m long, closed at both ends
    config = TrafficConfig(yield_timeout=10.0)
    pose = (0.9, 0.225, 0.0)
    path = np.array([[0.9, 0.225], [1.4, 0.225]])
    rules = Traffic("a", 0, TrafficBoard(), config)
    stamp, advice = backed_off(rules, pose, face_scan(0.19), path, costmap, config.yield_timeout)
    spot = advice.detour[-1]
    assert spot[0] < 0.3 and 0.1 < spot[1] < 0.35, spot  # at the far end of the dead end
    assert rules.phase is Phase.YIELD

    place, distance = farthest_place(costmap, (0.9, 0.225), np.array([[1.09, 0.225]]))
    assert place[0] < 0.3 and distance > 0.8
    assert farthest_place(costmap, (0.9, 0.225), np.zeros((0, 2))) is None
