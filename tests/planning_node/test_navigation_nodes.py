"""The planner and path follower nodes: map and goal in, /path out, ~/plan; one command per observation once in charge."""

import math

import numpy as np
from amr_interfaces.msg import LocalizedPose
from amr_interfaces.srv import PlanPath
from conftest import spin_until
from geometry_msgs.msg import PoseStamped, TwistStamped
from lifecycle_msgs.msg import Transition
from nav_msgs.msg import OccupancyGrid, Path
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

from amr_control.path_follower_node import PathFollowerNode
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
        self.cmd_vel = self.create_publisher(TwistStamped, "cmd_vel", 10)
        self.paths, self.commands = [], []
        self.create_subscription(Path, "path", self.paths.append, LATCHED)
        self.create_subscription(TwistStamped, "cmd_vel", self.commands.append, 10)
        self.plan = self.create_client(PlanPath, "planner/plan")


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


def test_the_planner_plans_once_localized_publishes_the_path_and_answers_its_service(ros_context, executor):
    planner, rig = PlannerNode(context=ros_context), Rig(ros_context)
    executor.add_node(planner)
    executor.add_node(rig)
    activate(planner)
    rig.map.publish(two_rooms())
    assert spin_until(executor, lambda: planner.planner is not None, 10.0)
    goal = PoseStamped()
    goal.pose.position.x, goal.pose.position.y = 3.5, 0.5
    assert spin_until(executor, lambda: rig.count_subscribers("goal_pose") > 0, 5.0)
    rig.goal.publish(goal)
    assert spin_until(executor, lambda: planner._goal is not None, 5.0)
    rig.pose.publish(pose(0.5, 0.5, localized=False))
    spin_until(executor, lambda: False, 0.3)
    assert rig.paths == []  # not localized: no plan
    rig.pose.publish(pose(0.5, 0.5))
    assert spin_until(executor, lambda: rig.paths, 10.0)
    path = rig.paths[-1]
    points = np.array([(p.pose.position.x, p.pose.position.y) for p in path.poses])
    assert path.header.frame_id == "map"
    assert np.allclose(points[0], (0.5, 0.5)) and np.allclose(points[-1], (3.5, 0.5))
    assert points[np.argmin(np.abs(points[:, 0] - 2.025)), 1] > 1.35  # through the door
    rig.pose.publish(pose(0.52, 0.5))  # on the path: no new plan
    spin_until(executor, lambda: False, 0.3)
    assert len(rig.paths) == 1

    assert spin_until(executor, lambda: rig.plan.service_is_ready(), 5.0)
    ok = call(executor, rig.plan, (0.5, 1.5), (3.0, 1.5))
    assert ok.success and len(ok.path.poses) > 10
    for goal_xy, words in (((math.nan, 1.0), "finite"), ((9.0, 1.0), "off the map"), ((2.025, 0.5), "occupied")):
        refused = call(executor, rig.plan, (0.5, 1.5), goal_xy)
        assert not refused.success and words in refused.message and not refused.path.poses
    planner.shut_down_cleanly()


def test_a_bad_planner_parameter_fails_configure_naming_it(ros_context):
    node = PlannerNode(context=ros_context, parameter_overrides=[Parameter("planner", value="dijkstra")])
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert "planner" in node.configure_error and node.state_label == "unconfigured"


def test_the_follower_answers_each_observation_once_in_charge_and_catches_up_only_an_unanswered_one(ros_context, executor):
    follower, rig = PathFollowerNode(context=ros_context), Rig(ros_context)
    executor.add_node(follower)
    executor.add_node(rig)
    activate(follower)
    assert spin_until(executor, lambda: rig.count_subscribers("scan") > 0 and rig.count_subscribers("pose") > 0, 5.0)
    step = 50_000_000

    def observe(k, localized=True):
        rig.pose.publish(pose(0.05 * k, 0.0, localized=localized, stamp_ns=(k + 1) * step))
        rig.scan.publish(open_scan((k + 1) * step))

    for k in range(3):  # no path yet: not in charge
        observe(k)
    spin_until(executor, lambda: False, 0.3)
    assert rig.commands == []
    rig.cmd_vel.publish(TwistStamped())  # another controller (the wall follower) answers observation 2
    assert spin_until(executor, lambda: len(rig.commands) == 1 and follower._unanswered is None, 5.0)

    path = Path()
    path.header.frame_id = "map"
    for x in np.arange(0.0, 2.0, 0.05):
        p = PoseStamped()
        p.pose.position.x = float(x)
        path.poses.append(p)
    rig.path_out.publish(path)
    assert spin_until(executor, lambda: follower.in_charge, 5.0)
    spin_until(executor, lambda: False, 0.2)
    assert len(rig.commands) == 1  # observation 2 was answered: nothing to catch up
    for k in range(3, 8):
        observe(k)
        assert spin_until(executor, lambda: len(rig.commands) == k - 1, 5.0)
    spin_until(executor, lambda: False, 0.2)
    assert len(rig.commands) == 6 and all(c.twist.linear.x > 0.0 for c in rig.commands[1:])
    observe(8, localized=False)  # a pose the localization does not vouch for: no command
    spin_until(executor, lambda: False, 0.3)
    assert len(rig.commands) == 6

    bad = Path()
    nan_pose = PoseStamped()
    nan_pose.pose.position.x = math.nan
    bad.poses.append(nan_pose)
    rig.path_out.publish(bad)
    assert spin_until(executor, lambda: not follower.in_charge, 5.0)
    observe(9)
    spin_until(executor, lambda: False, 0.3)
    assert len(rig.commands) == 6
    rig.path_out.publish(path)  # in charge again: observation 9, unanswered, gets its one command
    assert spin_until(executor, lambda: len(rig.commands) == 7, 5.0)
    spin_until(executor, lambda: False, 0.2)
    assert len(rig.commands) == 7
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


def test_the_planner_rasterizes_a_world_and_takes_its_goal_and_refuses_an_unreachable_one(ros_context, executor):
    planner = PlannerNode(context=ros_context, parameter_overrides=[Parameter("world", value="hard_maze.yaml")])
    rig = Rig(ros_context)
    executor.add_node(planner)
    executor.add_node(rig)
    activate(planner)
    assert planner._goal == (1.75, 1.75)
    assert spin_until(executor, lambda: rig.count_subscribers("pose") > 0, 5.0)
    rig.pose.publish(pose(-1.75, -1.75, math.pi / 2))
    assert spin_until(executor, lambda: rig.paths, 10.0)
    points = np.array([(p.pose.position.x, p.pose.position.y) for p in rig.paths[-1].poses])
    assert np.allclose(points[-1], (1.75, 1.75)) and not planner.planner.costmap.lethal_at(points).any()
    assert planner.set_parameters([Parameter("goal", value=[2.0, 2.0])])[0].successful  # in the outer wall
    rig.pose.publish(pose(-1.75, -1.75, math.pi / 2))
    spin_until(executor, lambda: False, 0.5)
    assert len(rig.paths) == 1 and planner.path is None  # refused with a log line, nothing published
    planner.shut_down_cleanly()
