"""The path and wall followers' shared shell (amr_control.controller_node) on a real robot's timer: nothing while the
node does not drive, zero with a warning naming its inputs while none came, a command computed from a new
observation, the last one held between observations, zero again once they are stale."""

import math

from lifecycle_msgs.msg import Transition
from nav_msgs.msg import Odometry
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from sensor_msgs.msg import LaserScan
from support.control import WarningLog

from amr_control.path_follower_node import PathFollowerNode
from amr_control.wall_follower_node import WallFollowerNode
from amr_interfaces.msg import LocalizedPose
from amr_util.throttle import Throttle


def scan(sec: int) -> LaserScan:
    message = LaserScan()
    message.header.stamp.sec = sec
    message.angle_min, message.angle_increment, message.range_min, message.range_max = 0.0, 2 * math.pi / 240, 0.12, 3.5
    message.ranges = [math.inf] * 240
    return message


def on_a_real_robot(node):
    node.set_parameters([Parameter("simulation", value=False)])
    assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    logger = WarningLog()
    node.get_logger = lambda: logger
    node._warnings = Throttle(0.0)  # every warning said
    return logger


def test_the_path_follower_on_its_timer_stops_without_observations_holds_between_them_and_stops_when_stale(
    ros_context,
):
    node = PathFollowerNode(context=ros_context)
    try:
        logger = on_a_real_robot(node)
        node._on_timer()
        assert node.commands_sent == 0, "no path: the node does not drive, it says nothing on /cmd_vel"
        node.follower.set_path([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])
        node._on_timer()
        assert node.commands_sent == 1 and node.last_command is None
        assert logger.lines == ["no localized /pose + /scan for 0.5 s: stopping"]
        pose = LocalizedPose(localized=True)
        pose.header.stamp.sec = 1
        pose.header.frame_id = "map"
        pose.pose.pose.orientation.w = 1.0
        node._on_pair(pose, scan(1))
        node._on_timer()
        computed = node.last_command
        assert node.commands_sent == 2 and computed is not None and computed.v > 0.0
        node._on_timer()  # no new observation: the same command again, not computed anew
        assert node.commands_sent == 3 and node.last_command is computed
        node._latest_time = node.get_clock().now() - Duration(seconds=1.0)
        node._on_timer()
        assert node.commands_sent == 4 and logger.lines[-1] == "no localized /pose + /scan for 0.5 s: stopping"
    finally:
        node.destroy_node()


def test_the_wall_follower_on_its_timer_stops_with_a_warning_until_a_pair_comes(ros_context):
    node = WallFollowerNode(context=ros_context)
    try:
        logger = on_a_real_robot(node)
        node._on_timer()
        assert node.commands_sent == 1 and logger.lines == ["no synchronized /odometry + /scan for 0.1 s: stopping"]
        odometry = Odometry()
        odometry.header.stamp.sec = 1
        node._on_pair(odometry, scan(1))
        node._on_timer()
        assert node.commands_sent == 2 and node.last_command is not None and len(logger.lines) == 1
    finally:
        node.destroy_node()
