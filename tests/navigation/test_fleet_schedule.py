"""Following a fleet plan together (amr_navigation.fleet_schedule): how far each robot may go, when it has
reached a waypoint, the route it is handed. Whole runs of the simulator's fleet driven by a plan:
tests/evaluation/test_fleet_plan_runs.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_navigation.fleet_schedule import Schedule
from amr_planning.fleet_lattice import Lattice
from amr_planning.fleet_paths import FleetPlan


def swap_plan() -> FleetPlan:
    """A corridor 0-1-2-3-4 (1 m apart) with a pocket 5 off vertex 2: robot 0 goes 0 -> 4 while robot 1 comes
    4 -> 0, stepping into the pocket and out again behind robot 0."""
    points = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [4, 0], [2, 1]], dtype=float)
    neighbours = ((1,), (0, 2), (1, 3, 5), (2, 4), (3,), (2,))
    paths = ((0, 1, 1, 1, 2, 3, 4), (4, 3, 2, 5, 5, 2, 1, 0))
    return FleetPlan(Lattice(points, neighbours, 1.0), paths, 0)


def test_a_robot_may_go_as_far_as_the_moves_it_waits_for_are_done():
    schedule = Schedule(swap_plan())
    # robot 0 may enter 1, but 2 only once robot 1 has left it (entered the pocket, its action 3)
    assert schedule.allowed(0) == 1
    assert schedule.allowed(1) == 3  # 3, 2 and the pocket: nobody is there before it
    for x, y in ((3.0, 0.0), (2.0, 0.0), (2.0, 1.0)):
        assert schedule.report(1, x, y)
    assert schedule.progress[1] == 3
    assert schedule.allowed(0) == 4  # 2, 3, 4 are free now
    # robot 1 may leave the pocket for 2 only once robot 0 has gone on to 3
    assert schedule.allowed(1) == 3
    schedule.report(0, 1.0, 0.0)
    schedule.report(0, 2.0, 0.0)
    assert schedule.allowed(1) == 3
    schedule.report(0, 3.0, 0.0)
    assert schedule.allowed(1) == 6


def test_a_waypoint_counts_as_reached_within_reach_in_order_and_never_past_what_is_allowed():
    schedule = Schedule(swap_plan())
    assert schedule.reach == pytest.approx(0.45)
    assert not schedule.report(0, 0.5, 0.0)  # 0.5 m from waypoint 1: not yet
    assert schedule.report(0, 0.6, 0.0)
    assert schedule.progress[0] == 1
    assert not schedule.report(0, 2.0, 0.0)  # at vertex 2, which it may not enter yet: not counted
    assert schedule.progress[0] == 1
    assert not schedule.report(1, 2.0, 0.0)  # waypoint 2 skipped (waypoint 1, vertex 3, comes first)
    assert schedule.progress[1] == 0


def test_the_route_goes_as_far_as_allowed_and_stops_before_it_turns_back():
    schedule = Schedule(swap_plan())
    route = schedule.route(1, 4.0, 0.0)
    assert route.tolist() == [[4.0, 0.0], [3.0, 0.0], [2.0, 0.0], [2.0, 1.0]]
    for x, y in ((3.0, 0.0), (2.0, 0.0), (2.0, 1.0)):
        schedule.report(1, x, y)
    for x, y in ((1.0, 0.0), (2.0, 0.0), (3.0, 0.0)):
        schedule.report(0, x, y)
    route = schedule.route(1, 2.0, 1.0)  # out of the pocket and on: 2, 1, 0, never back to where it stands
    assert route.tolist() == [[2.0, 1.0], [2.0, 0.0], [1.0, 0.0], [0.0, 0.0]]
    blocked = Schedule(swap_plan())
    assert blocked.route(0, 0.0, 0.0).tolist() == [[0.0, 0.0], [1.0, 0.0]]


def test_the_last_waypoint_is_the_robots_own_goal():
    schedule = Schedule(swap_plan(), goals=[(4.1, 0.05), (-0.1, 0.0)])
    assert schedule.waypoints[0][-1].tolist() == [4.1, 0.05]
    assert schedule.waypoints[1][-1].tolist() == [-0.1, 0.0]


def test_a_new_path_is_due_when_the_route_changes_and_a_second_after_the_follower_stopped_short():
    from amr_navigation.fleet_schedule import BLOCKED_RETRY, HandOver

    due = HandOver()
    assert due.due((0, 1), False, 0.0)  # the first route
    assert not due.due((0, 1), False, 0.05)
    assert due.due((1, 1), False, 0.1)  # progress moved
    assert not due.due((1, 1), True, 0.2)  # blocked from 0.2 s
    assert not due.due((1, 1), True, 0.2 + BLOCKED_RETRY / 2)
    assert due.due((1, 1), True, 0.2 + BLOCKED_RETRY)  # a second later: set off again
    assert not due.due((1, 1), True, 0.25 + BLOCKED_RETRY)  # and then a second after that, not at once
    assert not due.due((1, 1), False, 0.3 + BLOCKED_RETRY)  # unblocked: the wait starts anew next time
    assert not due.due((1, 1), True, 1.0 + BLOCKED_RETRY)
    assert due.due((1, 1), True, 1.0 + 2 * BLOCKED_RETRY)
    due.reset()
    assert due.due((1, 1), False, 5.0)


def test_the_pose_driven_by_is_the_estimate_while_sure_and_odometry_from_the_last_sure_one_after():
    from amr_navigation.fleet_schedule import DeadReckoning

    reckoning = DeadReckoning()

    # the odom frame is the map frame turned a quarter turn and shifted (1, 2)
    def to_map(x, y, theta):
        return (1.0 - y, 2.0 + x, theta + math.pi / 2)

    assert reckoning.pose((9.0, 9.0, 0.0), False, (0.0, 0.0, 0.0)) == (9.0, 9.0, 0.0)  # never sure: the estimate
    assert reckoning.pose(to_map(0.5, 0.0, 0.0), True, (0.5, 0.0, 0.0)) == pytest.approx(to_map(0.5, 0.0, 0.0))
    # unsure: the estimate (far off) is ignored; odometry moved 1 m along +x of the odom frame and turned
    driven = reckoning.pose((5.0, 5.0, 0.0), False, (1.5, 0.0, 0.3))
    assert driven == pytest.approx(to_map(1.5, 0.0, 0.3))
    driven = reckoning.pose((5.0, 5.0, 0.0), False, (1.5, 1.0, 0.3))
    assert driven == pytest.approx(to_map(1.5, 1.0, 0.3))
    # sure again: the estimate
    assert reckoning.pose((0.0, 3.0, 0.2), True, (1.5, 1.0, 0.3)) == (0.0, 3.0, 0.2)
