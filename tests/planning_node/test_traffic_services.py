"""What the traffic rules need of the planner and path follower nodes: ~/plan plans around a request's obstacle
points (refusing NaN, absurd counts and radii with the reason), and the path follower's speed limit caps, stops,
and expires."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import Point
from lifecycle_msgs.msg import Transition

from amr_control.path_follower_node import PathFollowerNode
from amr_interfaces.msg import SpeedLimit
from amr_interfaces.srv import PlanPath
from amr_maps.occupancy_grid import OccupancyGrid
from amr_planning.planner import Planner
from amr_planning.planner_node import MAX_OBSTACLES, PlannerNode, request_obstacles


def request(start, goal, obstacles=(), radius=0.0) -> PlanPath.Request:
    message = PlanPath.Request()
    message.start.pose.position.x, message.start.pose.position.y = start
    message.goal.pose.position.x, message.goal.pose.position.y = goal
    message.obstacles = [Point(x=float(x), y=float(y)) for x, y in obstacles]
    message.mark_radius = float(radius)
    return message


def open_grid(rows: int = 60, cols: int = 120, resolution: float = 0.025) -> OccupancyGrid:
    data = np.zeros((rows, cols), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyGrid(data, resolution)


@pytest.mark.parametrize(
    "obstacles, radius, reason",
    [
        ([(0.0, math.nan)], 0.05, "not finite"),
        ([(0.0, 0.0)], math.nan, "mark_radius"),
        ([(0.0, 0.0)], -0.1, "mark_radius"),
        ([(0.0, 0.0)], 5.0, "mark_radius"),
        ([(0.0, 0.0)] * (MAX_OBSTACLES + 1), 0.05, "obstacle points"),
    ],
)
def test_a_malformed_obstacle_request_is_refused_with_the_reason(obstacles, radius, reason):
    with pytest.raises(ValueError, match=reason):
        request_obstacles(request((0, 0), (1, 1), obstacles, radius))


def test_the_planner_node_plans_around_the_obstacles_of_a_request_and_refuses_garbage(ros_context):
    node = PlannerNode(context=ros_context)
    try:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
        node.planner = Planner(open_grid(), node.config)
        straight = node._on_plan_request(request((0.4, 0.75), (2.6, 0.75)), PlanPath.Response())
        around = node._on_plan_request(request((0.4, 0.75), (2.6, 0.75), [(1.5, 0.75)], 0.1), PlanPath.Response())
        assert straight.success and around.success, (straight.message, around.message)
        line = np.array([(p.pose.position.x, p.pose.position.y) for p in straight.path.poses])
        points = np.array([(p.pose.position.x, p.pose.position.y) for p in around.path.poses])
        assert np.abs(line[:, 1] - 0.75).max() < 0.03
        assert np.hypot(points[:, 0] - 1.5, points[:, 1] - 0.75).min() > 0.1 + 0.105
        refused = node._on_plan_request(request((0.4, 0.75), (2.6, 0.75), [(1.5, math.nan)], 0.1), PlanPath.Response())
        assert not refused.success and "obstacles refused" in refused.message and not refused.path.poses
        again = node._on_plan_request(request((0.4, 0.75), (2.6, 0.75)), PlanPath.Response())
        assert again.success and len(again.path.poses) == len(straight.path.poses)  # the marks were for one plan
    finally:
        node.destroy_node()


def limit(seconds: float, speed: float | None) -> SpeedLimit:
    message = SpeedLimit(limited=speed is not None, speed=0.0 if speed is None else speed)
    message.header.stamp.sec, message.header.stamp.nanosec = int(seconds), int(round((seconds % 1) * 1e9))
    return message


def test_the_path_follower_takes_the_latest_speed_limit_until_it_expires(ros_context):
    node = PathFollowerNode(context=ros_context)
    try:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        timeout = node.config.speed_limit_timeout
        assert node.speed_limit_for(10 * 10**9) is None  # none yet: uncapped
        node._on_speed_limit(limit(10.0, 0.05))
        assert node.speed_limit_for(10 * 10**9) == pytest.approx(0.05)
        assert node.speed_limit_for(int((10.0 + 0.5 * timeout) * 1e9)) == pytest.approx(0.05)
        assert node.speed_limit_for(int((10.0 + 1.5 * timeout) * 1e9)) is None  # expired
        node._on_speed_limit(limit(20.0, math.nan))  # garbage: a stop, never a NaN speed
        assert node.speed_limit_for(20 * 10**9) == 0.0
        node._on_speed_limit(limit(21.0, None))  # lifted
        assert node.speed_limit_for(21 * 10**9) is None
    finally:
        node.destroy_node()
