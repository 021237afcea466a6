"""The planner and path follower nodes: map and goal in, /path out, ~/plan; one command per observation once in
charge."""

import math

import numpy as np
from geometry_msgs.msg import PoseStamped, TwistStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import OccupancyGrid, Path
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from support.ros import spin_for, spin_until

from amr_control.path_follower_node import PathFollowerNode
from amr_interfaces.msg import LocalizedPose, NavigatorStatus, PathFollowerStatus
from amr_interfaces.srv import FollowPath, PlanPath
from amr_planning.planner_node import PlannerNode
from amr_util.qos import LATCHED


def two_rooms() -> OccupancyGrid:
    """4 x 2 m at 0.05 m, a wall across x = 2 m with a 0.5 m door at the top."""
    data = np.zeros((40, 80), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    data[:, 40] = 100
    data[28:38, 40] = 0
    message = OccupancyGrid()
    message.header.frame_id = "map"
    message.info.resolution, message.info.width, message.info.height = 0.05, 80, 40
    message.info.origin.orientation.w = 1.0
    message.data = data.ravel().tolist()
    return message


def pose(x, y, theta=0.0, localized=True, stamp_ns=0) -> LocalizedPose:
    message = LocalizedPose()
    message.header.frame_id = "map"
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    message.pose.pose.position.x, message.pose.pose.position.y = float(x), float(y)
    message.pose.pose.orientation.z, message.pose.pose.orientation.w = math.sin(theta / 2), math.cos(theta / 2)
    message.localized = localized
    return message


def open_scan(stamp_ns) -> LaserScan:
    scan = LaserScan()
    scan.header.stamp.sec, scan.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = 0.0, 2 * math.pi / 240, 0.12, 3.5
    scan.ranges = [math.inf] * 240
    return scan


class Rig(Node):
    def __init__(self, context):
        super().__init__("rig", context=context)
        self.map = self.create_publisher(OccupancyGrid, "map", LATCHED)
        self.pose = self.create_publisher(LocalizedPose, "pose", 10)
        self.goal = self.create_publisher(PoseStamped, "goal_pose", 10)
        self.scan = self.create_publisher(LaserScan, "scan", qos_profile_sensor_data)
        self.path_out = self.create_publisher(Path, "path", LATCHED)
        self.status = self.create_publisher(NavigatorStatus, "navigator/status", 10)
        self.paths, self.commands, self.follower_status = [], [], []
        self.create_subscription(Path, "path", self.paths.append, LATCHED)
        self.create_subscription(TwistStamped, "cmd_vel", self.commands.append, 10)
        self.create_subscription(PathFollowerStatus, "path_follower/status", self.follower_status.append, 10)
        self.plan = self.create_client(PlanPath, "planner/plan")
        self.follow = self.create_client(FollowPath, "path_follower/follow_path")

    def decide(self, k: int, controller: str, step: int = 50_000_000) -> None:
        """The navigator's status for observation k, naming `controller` ("" for nobody)."""
        status = NavigatorStatus(controller=controller, mode="FOLLOW" if controller == "path_follower" else "EXPLORE")
        status.header.stamp.sec, status.header.stamp.nanosec = divmod((k + 1) * step, 10**9)
        status.localized = True
        self.status.publish(status)


def activate(node):
    assert node.try_transition(Transition.TRANSITION_CONFIGURE), getattr(node, "configure_error", "")
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)


def call(executor, client, start, goal):
    request = PlanPath.Request()
    request.start.pose.position.x, request.start.pose.position.y = start
    request.goal.pose.position.x, request.goal.pose.position.y = goal
    future = client.call_async(request)
    assert spin_until(executor, future.done, 10.0)
    return future.result()


def test_the_planner_answers_its_service_on_the_map_only_while_active_and_logs_a_failure_once(ros_context, executor):
    planner, rig = PlannerNode(context=ros_context), Rig(ros_context)
    executor.add_node(planner)
    executor.add_node(rig)
    assert planner.try_transition(Transition.TRANSITION_CONFIGURE)
    rig.map.publish(two_rooms())
    assert spin_until(executor, lambda: planner.planner is not None, 10.0)
    assert spin_until(executor, lambda: rig.plan.service_is_ready(), 5.0)
    inactive = call(executor, rig.plan, (0.5, 1.5), (3.0, 1.5))
    assert not inactive.success and "inactive" in inactive.message and "only while active" in inactive.message
    assert planner.try_transition(Transition.TRANSITION_ACTIVATE)
    ok = call(executor, rig.plan, (0.5, 0.5), (3.5, 0.5))
    points = np.array([(p.pose.position.x, p.pose.position.y) for p in ok.path.poses])
    assert ok.success and ok.path.header.frame_id == "map"
    assert np.allclose(points[0], (0.5, 0.5)) and np.allclose(points[-1], (3.5, 0.5))
    assert points[np.argmin(np.abs(points[:, 0] - 2.025)), 1] > 1.35  # through the door
    assert rig.paths == []  # the planner answers; publishing /path is the navigator's
    for goal_xy, words, refused_goal in (
        ((math.nan, 1.0), "finite", True),
        ((9.0, 1.0), "off the map", True),
        ((2.025, 0.5), "occupied", True),
    ):
        refused = call(executor, rig.plan, (0.5, 1.5), goal_xy)
        assert not refused.success and words in refused.message and not refused.path.poses
        assert refused.goal_refused is refused_goal
    start_refused = call(executor, rig.plan, (2.025, 0.5), (0.5, 1.5))
    assert not start_refused.success and not start_refused.goal_refused
    logged = []
    planner.get_logger().warning = lambda text, **kwargs: logged.append(text)
    for _ in range(3):  # a navigator retrying: the same reason is logged once
        call(executor, rig.plan, (2.025, 0.5), (0.5, 1.5))
    assert logged == []
    call(executor, rig.plan, (0.5, 1.5), (9.0, 1.0))
    assert len(logged) == 1 and "off the map" in logged[0]
    assert planner.shut_down()
    assert spin_until(executor, lambda: not rig.plan.service_is_ready(), 5.0)  # gone after shutdown


def test_a_bad_planner_parameter_fails_configure_naming_it(ros_context):
    node = PlannerNode(context=ros_context, parameter_overrides=[Parameter("planner", value="dijkstra")])
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert "planner" in node.configure_error and node.state_label == "unconfigured"


def straight_path() -> Path:
    path = Path()
    path.header.frame_id = "map"
    for x in np.arange(0.0, 2.0, 0.05):
        p = PoseStamped()
        p.pose.position.x = float(x)
        path.poses.append(p)
    return path


def test_the_follower_alone_answers_each_localized_observation_once_it_has_a_path(ros_context, executor):
    follower, rig = PathFollowerNode(context=ros_context), Rig(ros_context)
    executor.add_node(follower)
    executor.add_node(rig)
    activate(follower)
    assert spin_until(executor, lambda: rig.count_subscribers("scan") > 0 and rig.count_subscribers("pose") > 0, 5.0)
    assert not any(
        topic == "/cmd_vel" for topic, _ in follower.get_subscriber_names_and_types_by_node("path_follower", "/")
    ), "no controller listens to /cmd_vel"
    step = 50_000_000

    def observe(k, localized=True):
        rig.pose.publish(pose(0.05 * k, 0.0, localized=localized, stamp_ns=(k + 1) * step))
        rig.scan.publish(open_scan((k + 1) * step))

    for k in range(3):  # no path yet: not in charge
        observe(k)
    spin_for(executor, 0.3)
    assert rig.commands == []
    rig.path_out.publish(straight_path())
    assert spin_until(executor, lambda: follower.in_charge, 5.0)
    for k in range(3, 8):
        observe(k)
        assert spin_until(executor, lambda k=k: len(rig.commands) == k - 2, 5.0)
    spin_for(executor, 0.2)
    assert len(rig.commands) == 5 and all(c.twist.linear.x > 0.0 for c in rig.commands)
    assert len(rig.follower_status) == 5 and rig.follower_status[-1].state == "TRACK"
    observe(8, localized=False)  # a pose the localization does not vouch for: no command
    spin_for(executor, 0.3)
    assert len(rig.commands) == 5

    bad = Path()
    nan_pose = PoseStamped()
    nan_pose.pose.position.x = math.nan
    bad.poses.append(nan_pose)
    rig.path_out.publish(bad)
    assert spin_until(executor, lambda: not follower.in_charge, 5.0)
    observe(9)
    spin_for(executor, 0.3)
    assert len(rig.commands) == 5
    follower.shut_down_cleanly()


def test_a_navigated_follower_answers_only_what_the_navigator_gives_it_and_a_held_observation_on_a_new_decision(
    ros_context, executor
):
    follower = PathFollowerNode(context=ros_context, parameter_overrides=[Parameter("navigated", value=True)])
    rig = Rig(ros_context)
    executor.add_node(follower)
    executor.add_node(rig)
    activate(follower)
    assert spin_until(
        executor, lambda: rig.count_subscribers("navigator/status") > 0 and rig.follow.service_is_ready(), 5.0
    )
    request = FollowPath.Request(path=straight_path())
    future = rig.follow.call_async(request)
    assert spin_until(executor, future.done, 5.0) and future.result().success
    refused = rig.follow.call_async(FollowPath.Request(path=Path()))
    assert spin_until(executor, refused.done, 5.0) and not refused.result().success and refused.result().message
    assert spin_until(executor, lambda: rig.count_subscribers("scan") > 0, 5.0)
    step = 50_000_000

    def observe(k, controller):
        rig.pose.publish(pose(0.05 * k, 0.0, stamp_ns=(k + 1) * step))
        rig.scan.publish(open_scan((k + 1) * step))
        rig.decide(k, controller)

    # the path above was refused (empty): give it again
    future = rig.follow.call_async(FollowPath.Request(path=straight_path()))
    assert spin_until(executor, future.done, 5.0) and future.result().success
    observe(0, "wall_follower")
    observe(1, "path_follower")
    assert spin_until(executor, lambda: len(rig.commands) == 1, 5.0)
    observe(2, "")  # nobody: the robot is held on observation 2
    spin_for(executor, 0.3)
    assert len(rig.commands) == 1
    rig.decide(2, "path_follower")  # a new decision for the held observation (a goal arrived)
    assert spin_until(executor, lambda: len(rig.commands) == 2, 5.0)
    rig.decide(2, "path_follower")  # the same decision again: answered already, nothing more
    observe(3, "wall_follower")
    spin_for(executor, 0.3)
    assert len(rig.commands) == 2
    follower.shut_down_cleanly()


def test_live_tunables_apply_and_structural_parameters_are_refused_while_configured(ros_context):
    follower, planner = PathFollowerNode(context=ros_context), PlannerNode(context=ros_context)
    for node in (follower, planner):
        assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert follower.set_parameters([Parameter("lookahead_distance", value=0.3)])[0].successful
    assert follower.follower.config.lookahead_distance == 0.3
    refused = follower.set_parameters([Parameter("min_linear_speed", value=0.5)])[0]  # above linear_speed
    assert not refused.successful and "min_linear_speed" in refused.reason
    assert not follower.set_parameters([Parameter("dt", value=0.1)])[0].successful
    assert planner.set_parameters([Parameter("safety_margin", value=0.05)])[0].successful
    assert planner.config.safety_margin == 0.05
    refused = planner.set_parameters([Parameter("planner", value="prm")])[0]
    assert not refused.successful and "read-only while configured" in refused.reason


def test_the_planner_rasterizes_a_world_for_standalone_use_and_refuses_a_goal_in_a_wall(ros_context, executor):
    planner = PlannerNode(context=ros_context, parameter_overrides=[Parameter("world", value="hard_maze.yaml")])
    rig = Rig(ros_context)
    executor.add_node(planner)
    executor.add_node(rig)
    activate(planner)
    assert spin_until(executor, lambda: rig.plan.service_is_ready(), 5.0)
    answer = call(executor, rig.plan, (-1.75, -1.75), (1.75, 1.75))  # hard_maze's start to its goal
    points = np.array([(p.pose.position.x, p.pose.position.y) for p in answer.path.poses])
    assert answer.success and np.allclose(points[-1], (1.75, 1.75))
    assert not planner.planner.costmap.lethal_at(points).any()
    refused = call(executor, rig.plan, (-1.75, -1.75), (2.0, 2.0))  # in the outer wall
    assert not refused.success and refused.goal_refused and not refused.path.poses
    planner.shut_down_cleanly()
