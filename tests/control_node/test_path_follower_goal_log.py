"""The path follower says "goal reached" (info) only at the end of the path that ends at the goal: a fleet route is
handed over in legs, and the end of every other leg is logged at debug."""

import math

import pytest
from lifecycle_msgs.msg import Transition
from rclpy.parameter import Parameter
from sensor_msgs.msg import LaserScan

from amr_control.path_follower_node import PathFollowerNode, ends_at_goal
from amr_interfaces.msg import LocalizedPose, NavigatorStatus


class Logger:
    def __init__(self):
        self.lines = []

    def info(self, text, **_):
        self.lines.append(("info", text))

    def debug(self, text, **_):
        self.lines.append(("debug", text))

    def warning(self, text, **_):
        self.lines.append(("warning", text))

    def error(self, text, **_):
        self.lines.append(("error", text))


def at(x, y, stamp_ns):
    pose = LocalizedPose(localized=True)
    pose.header.frame_id = "map"
    pose.header.stamp.sec, pose.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    pose.pose.pose.position.x, pose.pose.pose.position.y = float(x), float(y)
    pose.pose.pose.orientation.w = 1.0
    scan = LaserScan()
    scan.header.stamp = pose.header.stamp
    scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max = 0.0, 2 * math.pi / 240, 0.12, 3.5
    scan.ranges = [math.inf] * 240
    return pose, scan


def test_ends_at_goal():
    assert ends_at_goal((1.0, 0.0), None, 0.05)  # no navigator's goal: the path is the goal
    assert ends_at_goal((1.0, 0.0), (1.03, 0.0), 0.05)
    assert not ends_at_goal((1.0, 0.0), (2.0, 0.0), 0.05)


@pytest.mark.parametrize(("goal", "level"), [((2.0, 0.0), "debug"), ((1.0, 0.0), "info")])
def test_the_end_of_a_leg_is_not_the_goal(ros_context, goal, level):
    node = PathFollowerNode(context=ros_context, parameter_overrides=[Parameter("navigated", value=True)])
    try:
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.configure_error
        assert node.try_transition(Transition.TRANSITION_ACTIVATE)
        logger = Logger()
        node.get_logger = lambda: logger
        node.follower.set_path([(0.0, 0.0), (0.5, 0.0), (1.0, 0.0)])
        status = NavigatorStatus(controller="path_follower", mode="FOLLOW", has_goal=True, localized=True)
        status.goal.x, status.goal.y = goal
        node._on_navigator_status(status)
        for k in range(3):
            node._compute(*at(1.0, 0.0, (k + 1) * 50_000_000))
        assert node.last_command.reached
        said = [line for line in logger.lines if "reached" in line[1]]
        assert len(said) == 1 and said[0][0] == level, logger.lines
        assert (said[0][1] == "goal reached") is (level == "info")
    finally:
        node.destroy_node()
