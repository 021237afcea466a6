"""The path follower checks its inputs' stamps as every node does (the synchronizer's add_stamped, amr_util.sync's
checked_stamp): a negative or malformed stamp is dropped with a warning, never raised out of the callback (rclpy's
Time.from_msg raises ValueError on a negative sec), and the inputs after it are answered."""

import math

from lifecycle_msgs.msg import Transition
from sensor_msgs.msg import LaserScan
from support.control import WarningLog

from amr_control.path_follower_node import POSE, SCAN, PathFollowerNode
from amr_interfaces.msg import LocalizedPose, SpeedLimit
from amr_util.throttle import Throttle


def stamped(message, sec, nanosec):
    message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
    return message


def pose_and_scan(sec, nanosec):
    pose = stamped(LocalizedPose(localized=True), sec, nanosec)
    pose.header.frame_id = "map"
    pose.pose.pose.orientation.w = 1.0
    scan = stamped(LaserScan(), sec, nanosec)
    scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = 0.0, 2 * math.pi / 240, 0.12, 3.5
    scan.ranges = [math.inf] * 240
    return pose, scan


def test_a_bad_stamp_is_dropped_with_a_warning_and_the_next_pair_is_answered(ros_context):
    node = PathFollowerNode(context=ros_context)
    try:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        logger = WarningLog()
        node.get_logger = lambda: logger
        node._warnings = Throttle(0.0)  # every warning said, not one per 2 s
        node.follower.set_path([(0.0, 0.0), (0.5, 0.0), (1.0, 0.0)])
        node._on_speed_limit(stamped(SpeedLimit(limited=True, speed=0.05), 1, 0))
        for sec, nanosec in ((-1, 0), (1, 2_000_000_000)):
            pose, scan = pose_and_scan(sec, nanosec)
            node._on_message(POSE, pose)
            node._on_message(SCAN, scan)
            node._on_speed_limit(stamped(SpeedLimit(limited=True, speed=0.2), sec, nanosec))
        assert node.commands_sent == 0
        assert sum("negative stamp" in line for line in logger.lines) == 3, logger.lines  # pose, scan, limit
        assert sum("malformed stamp (nanosec 2000000000)" in line for line in logger.lines) == 3, logger.lines
        assert sum(line.startswith("speed limit: ") for line in logger.lines) == 2, logger.lines
        assert node.speed_limit_for(1_000_000_000) == 0.05  # the limit before the bad ones stands
        pose, scan = pose_and_scan(1, 50_000_000)
        node._on_message(POSE, pose)
        node._on_message(SCAN, scan)
        assert node.commands_sent == 1
    finally:
        node.destroy_node()
