"""The fleet plan through ROS, node by node, its callbacks called directly: the navigator's `coordination: plan`
(the traffic rules until a route, then the route: paths handed to the path follower, holds, dead reckoning, the goal
reached, back to the rules on NONE, a malformed route refused), the fleet_planner node (NONE, then HOLD and routes
once every robot's navigator is confident, nothing while a navigator does not listen, garbage statuses refused), and
the path follower driving an unsure observation from the navigator's pose."""

from __future__ import annotations

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rclpy.task import Future

from amr_interfaces.msg import FleetRoute, LocalizedPose, NavigatorStatus, PathFollowerStatus
from amr_interfaces.srv import FollowPath
from amr_maps.messages import grid_message
from amr_maps.rasterize import rasterize_world
from amr_maps.world import world_from_dict
from amr_navigation.fleet_schedule import BLOCKED_RETRY
from amr_util.messages import quaternion

WALLS = [
    [-2, -0.2, 2, -0.2],
    [-2, 0.2, -0.2, 0.2],
    [0.2, 0.2, 2, 0.2],
    [-0.2, 0.2, -0.2, 0.7],
    [0.2, 0.2, 0.2, 0.7],
    [-0.2, 0.7, 0.2, 0.7],
    [-2, -0.2, -2, 0.2],
    [2, -0.2, 2, 0.2],
]
"""a corridor 4 m long with a pocket off its middle."""


def corridor_map():
    world = world_from_dict({"name": "corridor", "wall_thickness": 0.05, "walls": WALLS, "start": [-1.6, 0, 0]})
    return grid_message(rasterize_world(world, 0.02), Time(sec=1))


class Recorder:
    """Stands in for a publisher: keeps what is published."""

    def __init__(self, subscribers: int = 1) -> None:
        self.messages: list = []
        self.subscribers = subscribers

    def publish(self, message) -> None:
        self.messages.append(message)

    def get_subscription_count(self) -> int:
        return self.subscribers


class FollowPathClient:
    """Stands in for the path follower's ~/follow_path: every path accepted at once."""

    srv_name = "/r1/path_follower/follow_path"

    def __init__(self) -> None:
        self.paths: list = []

    def service_is_ready(self) -> bool:
        return True

    def call_async(self, request):
        self.paths.append(np.array([(p.pose.position.x, p.pose.position.y) for p in request.path.poses]))
        future = Future()
        future.set_result(FollowPath.Response(success=True))
        return future


def stamp(seconds: float) -> Time:
    return Time(sec=int(seconds), nanosec=int(round((seconds % 1) * 1e9)))


def pose_message(seconds: float, x: float, y: float, theta: float, localized: bool = True) -> LocalizedPose:
    message = LocalizedPose(localized=localized)
    message.header.stamp, message.header.frame_id = stamp(seconds), "map"
    message.pose.pose.position.x, message.pose.pose.position.y = x, y
    message.pose.pose.orientation = quaternion(theta)
    return message


def odometry_message(seconds: float, x: float, y: float, theta: float) -> Odometry:
    message = Odometry()
    message.header.stamp = stamp(seconds)
    message.pose.pose.position.x, message.pose.pose.position.y = x, y
    message.pose.pose.orientation = quaternion(theta)
    return message


def route_message(
    state: str, waypoints=(), *, final: bool = False, plan: int = 1, progress: int = 0, total: int = 4
) -> FleetRoute:
    message = FleetRoute(state=state, final=final, plan=plan, progress=progress, total=total)
    message.header.frame_id = "map"
    message.waypoints = [Point(x=float(x), y=float(y)) for x, y in waypoints]
    return message


@pytest.fixture
def navigator(ros_context):
    from amr_navigation.navigator_node import NavigatorNode

    node = NavigatorNode(
        context=ros_context,
        namespace="/r1",
        parameter_overrides=[
            Parameter("traffic", value=True),
            Parameter("coordination", value="plan"),
            Parameter("goal", value=[1.6, 0.0]),
        ],
    )
    assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    for name in ("status", "speed_limit", "traffic", "path"):
        node._outputs[name] = Recorder()
    node._service_clients["follow"] = FollowPathClient()
    node._on_map(corridor_map())
    yield node
    node.destroy_node()


def observe(node, seconds: float, estimate, odometry, localized: bool = True):
    node._on_odometry(odometry_message(seconds, *odometry))
    node._on_pose(pose_message(seconds, *estimate, localized=localized))
    return node._outputs["status"].messages[-1], node._outputs["speed_limit"].messages[-1]


def test_coordination_plan_needs_the_traffic_rules(ros_context):
    from amr_navigation.navigator_node import NavigatorNode

    node = NavigatorNode(
        context=ros_context, namespace="/r1", parameter_overrides=[Parameter("coordination", value="plan")]
    )
    try:
        assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert "coordination" in node.configure_error and "traffic" in node.configure_error
    finally:
        node.destroy_node()


def test_the_navigator_follows_its_route_holds_reckons_and_reaches_its_goal(navigator):
    node, follow = navigator, navigator._service_clients["follow"]
    node._on_route(route_message("FOLLOW", [(-1.2, 0.0), (-0.8, 0.0)], progress=0, total=4))
    status, limit = observe(node, 2.0, (-1.6, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert status.controller == "path_follower" and status.mode == "FOLLOW", status
    assert status.confident and status.confidence == 1.0  # localized without a probability: counts as 1
    assert not limit.limited
    assert len(follow.paths) == 1
    path = follow.paths[0]
    assert np.allclose(path[0], (-1.6, 0.0)) and np.allclose(path[-1], (-0.8, 0.0))
    assert min(np.hypot(*(path - (-1.2, 0.0)).T)) < 1e-6  # through the first waypoint
    observe(node, 2.05, (-1.58, 0.0, 0.0), (0.02, 0.0, 0.0))
    assert len(follow.paths) == 1  # nothing changed: no new path

    # the localizer unsure (its estimate far off): the pose driven by is odometry from the last sure estimate
    status, _ = observe(node, 2.1, (5.0, 5.0, 1.0), (0.12, 0.01, 0.05), localized=False)
    assert status.controller == "path_follower" and not status.localized
    assert not status.confident and status.confidence == 0.0
    assert (status.pose.position.x, status.pose.position.y) == pytest.approx((-1.48, 0.01))

    # blocked: a new path from where it stands BLOCKED_RETRY s later, not before
    node._on_follower(PathFollowerStatus(state="BLOCKED", header=status.header))
    observe(node, 2.15, (-1.48, 0.01, 0.05), (0.12, 0.01, 0.05))
    assert len(follow.paths) == 1
    observe(node, 2.2 + BLOCKED_RETRY, (-1.48, 0.01, 0.05), (0.12, 0.01, 0.05))
    assert len(follow.paths) == 2 and np.allclose(follow.paths[1][0], (-1.48, 0.01))

    # HOLD: the path follower still answers, with a speed limit of 0
    node._on_route(route_message("HOLD", plan=2))
    status, limit = observe(node, 4.0, (-1.48, 0.01, 0.05), (0.12, 0.01, 0.05))
    assert status.controller == "path_follower" and limit.limited and limit.speed == 0.0

    # the last stretch: the goal at its end, reached when the path follower says so
    node._on_route(route_message("FOLLOW", [(-0.8, 0.0), (1.6, 0.0)], final=True, plan=2, progress=3, total=4))
    status, limit = observe(node, 4.05, (-1.48, 0.01, 0.05), (0.12, 0.01, 0.05))
    assert len(follow.paths) == 3 and np.allclose(follow.paths[2][-1], (1.6, 0.0))
    assert status.mode == "FOLLOW" and not limit.limited
    node._on_follower(PathFollowerStatus(state="REACHED", reached=True, header=status.header))
    status, limit = observe(node, 4.1, (1.6, 0.0, 0.0), (3.2, 0.0, 0.0))
    assert status.mode == "REACHED" and status.controller == "path_follower" and limit.limited and limit.speed == 0.0
    # each observation on the route is posted on /traffic with the pose driven by
    assert node.board.get("r1").pose == pytest.approx((1.6, 0.0, 0.0))

    # NONE: back to the traffic rules (the navigator's own decisions)
    node._on_route(route_message("NONE"))
    assert node._route is None


def test_a_malformed_route_is_refused_and_the_previous_one_stands(navigator):
    node = navigator
    node._on_route(route_message("FOLLOW", [(-1.2, 0.0)]))
    bad = [route_message("GO", [(0.0, 0.0)]), route_message("FOLLOW", []), route_message("FOLLOW", [(math.nan, 0.0)])]
    other = route_message("FOLLOW", [(0.0, 0.0)])
    other.header.frame_id = "odom"
    for message in bad + [other]:
        node._on_route(message)  # must not raise
    assert node.routes_refused == 4
    assert node._route.waypoints[0][0] == -1.2


def test_the_path_follower_drives_an_unsure_observation_from_the_navigators_pose():
    from amr_control.path_follower_node import driven_pose

    status = NavigatorStatus(controller="path_follower")
    status.pose.position.x, status.pose.position.y = 1.0, 2.0
    sure = pose_message(1.0, 5.0, 5.0, 0.0, localized=True)
    assert driven_pose(sure, status) is sure
    unsure = pose_message(1.0, 5.0, 5.0, 0.0, localized=False)
    driven = driven_pose(unsure, status)
    assert (driven.pose.pose.position.x, driven.pose.pose.position.y) == (1.0, 2.0)
    assert driven.header.stamp == unsure.header.stamp


@pytest.fixture
def planner(ros_context):
    from amr_navigation.fleet_planner_node import FleetPlannerNode

    node = FleetPlannerNode(context=ros_context, parameter_overrides=[Parameter("robots", value=["r1", "r2"])])
    assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
    node._routes = {name: Recorder() for name in ("r1", "r2")}
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    yield node
    node.destroy_node()


def status_message(
    seconds: float, x: float, y: float, confident: bool, goal, localized: bool | None = None
) -> NavigatorStatus:
    """A navigator's status: its verdict `confident` (the localizer's `localized` the same unless given)."""
    localized = confident if localized is None else localized
    message = NavigatorStatus(localized=localized, confident=confident, has_goal=goal is not None)
    message.header.stamp, message.header.frame_id = stamp(seconds), "map"
    message.pose.position.x, message.pose.position.y = x, y
    if goal is not None:
        message.goal.x, message.goal.y = goal
    return message


def test_the_fleet_planner_says_none_then_holds_and_hands_out_routes_once_all_are_confident(planner):
    node = planner
    states = lambda name: [m.state for m in node._routes[name].messages]  # noqa: E731
    assert states("r1") == ["NONE"] and states("r2") == ["NONE"]  # on activation: the traffic rules
    node._on_map(corridor_map())
    r1, r2 = node._status_callback("r1"), node._status_callback("r2")
    r1(status_message(1.0, -1.6, 0.0, True, (1.6, 0.0)))
    r2(status_message(1.0, 1.6, 0.0, False, (-1.6, 0.0), localized=True))
    assert states("r1") == ["NONE"]  # r2's localizer says localized, its navigator is not confident: no plan
    r2(status_message(1.05, 1.6, 0.0, True, (-1.6, 0.0), localized=False))
    assert states("r1") == ["NONE", "HOLD"]  # every navigator confident (r2's through a dip of localized)
    # planned on the worker thread, adopted when done
    assert node.wait_for_plan(30.0)
    assert states("r1") == ["NONE", "HOLD", "FOLLOW"] and states("r2") == ["NONE", "HOLD", "FOLLOW"]
    route = node._routes["r1"].messages[-1]
    assert route.plan == 1 and route.header.frame_id == "map" and route.waypoints
    assert all(math.isfinite(p.x) and math.isfinite(p.y) for p in route.waypoints)
    # garbage statuses are refused, not raised; nothing published for them
    before = len(node._routes["r1"].messages)
    r1(status_message(1.1, math.nan, 0.0, True, (1.6, 0.0)))
    wrong = status_message(1.1, -1.6, 0.0, True, (1.6, 0.0))
    wrong.header.frame_id = "odom"
    r1(wrong)
    assert node.statuses_refused == 2 and len(node._routes["r1"].messages) == before
    # deactivated: every robot back to the rules
    assert node.try_transition(Transition.TRANSITION_DEACTIVATE)
    assert states("r1")[-1] == "NONE" and states("r2")[-1] == "NONE"


def test_the_fleet_planner_does_not_plan_while_a_navigator_does_not_listen(planner):
    node = planner
    node._routes["r2"].subscribers = 0  # r2's navigator runs coordination: rules
    node._on_map(corridor_map())
    for stamp in (1.0, 5.0):  # confident: only r2's deaf navigator holds the plan back
        node._status_callback("r1")(status_message(stamp, -1.6, 0.0, True, (1.6, 0.0)))
        node._status_callback("r2")(status_message(stamp, 1.6, 0.0, True, (-1.6, 0.0)))
    assert node.coordinator.plan_due()
    assert [m.state for m in node._routes["r1"].messages] == ["NONE"] and node.coordinator.plans == 0


def test_the_fleet_planner_refuses_a_configuration_without_robots(ros_context):
    from amr_navigation.fleet_planner_node import FleetPlannerNode

    node = FleetPlannerNode(context=ros_context)
    try:
        assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
        assert "world, robots" in node.configure_error
    finally:
        node.destroy_node()


def test_the_fleet_planner_plans_on_a_worker_thread_and_its_executor_stays_responsive(planner, monkeypatch):
    """The plan is held up (an event the test sets); statuses keep being read meanwhile, each callback returns at
    once, and the routes come through the executor (the worker's guard condition) once the plan is done. Were the
    plan made in the status callback, the callback would block until the event (10 s) and this test fail."""
    import threading
    import time

    import amr_navigation.fleet_planner_node as module
    from amr_util.lean_executor import LeanExecutor

    release, started = threading.Event(), threading.Event()
    compute = module.compute_plan

    def slow(job):
        started.set()
        release.wait(10.0)
        return compute(job)

    monkeypatch.setattr(module, "compute_plan", slow)
    node = planner
    node._on_map(corridor_map())
    executor = LeanExecutor(context=node.context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        r1, r2 = node._status_callback("r1"), node._status_callback("r2")
        for seconds in (1.0, 4.05):
            r1(status_message(seconds, -1.6, 0.0, True, (1.6, 0.0)))
            began = time.monotonic()
            r2(status_message(seconds, 1.6, 0.0, True, (-1.6, 0.0)))
        assert time.monotonic() - began < 2.0  # the callback that made the plan due returned at once
        assert started.wait(5.0) and node.coordinator.planning
        began = time.monotonic()
        r1(status_message(4.1, -1.55, 0.0, True, (1.6, 0.0)))  # read while the plan is made
        assert time.monotonic() - began < 2.0
        assert node.coordinator.statuses["r1"].x == -1.55
        assert [m.state for m in node._routes["r1"].messages] == ["NONE", "HOLD"]
        release.set()
        deadline = time.monotonic() + 30.0
        while node._routes["r1"].messages[-1].state != "FOLLOW" and time.monotonic() < deadline:
            time.sleep(0.05)
        assert node._routes["r1"].messages[-1].state == "FOLLOW" and not node.coordinator.planning
    finally:
        release.set()
        executor.shutdown(timeout_sec=5.0)
        spinner.join(5.0)


def test_an_expired_route_sends_the_navigator_back_to_its_own_planning(navigator):
    """A route expires route_lifetime (30 s) after its stamp without a newer word (the fleet planner gone, or still
    planning after a HOLD): the navigator drops it and plans by itself; a renewed route is followed again."""
    node, follow = navigator, navigator._service_clients["follow"]
    route = route_message("FOLLOW", [(-1.2, 0.0), (-0.8, 0.0)], progress=0, total=4)
    route.header.stamp = stamp(1.0)
    node._on_route(route)
    assert node._route.expires == pytest.approx(31.0)
    status, _ = observe(node, 30.9, (-1.6, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert node._route is not None and status.controller == "path_follower" and len(follow.paths) == 1
    observe(node, 31.05, (-1.6, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert node._route is None  # expired: its own planning (the traffic rules), the route's path not handed again
    assert len(follow.paths) == 1
    route.header.stamp = stamp(31.1)  # renewed
    node._on_route(route)
    observe(node, 31.15, (-1.6, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert node._route is not None and node._route.expires == pytest.approx(61.1) and len(follow.paths) == 2


def test_a_post_that_says_nothing_new_is_not_published_again_before_its_keep_alive(navigator):
    """Every post on /traffic wakes every other navigator: one that says what the last one did (the robot stood, or
    moved under 2 cm) waits for the keep-alive (0.5 s), a real change goes out at once."""
    from amr_navigation.navigator_node import POST_KEEP_ALIVE, same_post
    from amr_navigation.traffic_board import TrafficPost

    node = navigator
    node.set_parameters([Parameter("use_sim_time", value=False)])
    node._on_route(route_message("HOLD", plan=1))
    posts = node._outputs["traffic"].messages
    observe(node, 2.0, (-1.6, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert len(posts) == 1
    for step in range(5):  # standing, held: nothing new
        observe(node, 2.05 + 0.05 * step, (-1.6, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert len(posts) == 1
    node._last_post = (node._last_post[0], node._last_post[1] - POST_KEEP_ALIVE)  # the keep-alive is due
    observe(node, 2.4, (-1.6, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert len(posts) == 2
    observe(node, 2.45, (-1.55, 0.0, 0.0), (0.05, 0.0, 0.0))  # moved 5 cm: published at once
    assert len(posts) == 3 and posts[-1].pose.x == pytest.approx(-1.55)
    a = TrafficPost("r1", 0, (0.0, 0.0, 0.0), np.array([[0.0, 0.0], [1.0, 0.0]]))
    assert same_post(a, TrafficPost("r1", 0, (0.01, 0.0, 0.02), np.array([[0.01, 0.0], [1.0, 0.0]])))
    assert not same_post(a, TrafficPost("r1", 0, (0.0, 0.0, 0.0), np.array([[0.0, 0.0], [1.0, 0.5]])))
    assert not same_post(a, TrafficPost("r1", 0, (0.0, 0.0, 0.0), np.array([[0.0, 0.0], [1.0, 0.0]]), passive=True))
    assert not same_post(a, TrafficPost("r1", 0, None, None))
