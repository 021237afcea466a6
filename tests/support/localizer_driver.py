"""A stand-in controller for the localizer node tests: answers each /pose with an arc and records what it saw."""

from __future__ import annotations

import math

from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node

from amr_interfaces.msg import BeaconRanges, LocalizedPose
from amr_util.geometry import wrap_angle, yaw_from_quaternion
from amr_util.stamps import stamp_nanoseconds

STEPS = 40


def stamp_ns(message) -> int:
    return stamp_nanoseconds(message.header.stamp)


class Driver(Node):
    """Answers each of the first `steps` /pose messages with an arc (v, w) (a stand-in controller); records the
    poses, the /beacons readings and the ground truth by stamp."""

    def __init__(self, context, steps: int = STEPS, v: float = 0.1, w: float = 0.3) -> None:
        super().__init__("driver", context=context)
        self.steps, self.v, self.w = steps, v, w
        self.poses: list[LocalizedPose] = []
        self.readings: list[BeaconRanges] = []
        self.truth: dict[int, Odometry] = {}
        self.cmd_vel = self.create_publisher(TwistStamped, "cmd_vel", 10)
        self.create_subscription(LocalizedPose, "pose", self._on_pose, 100)
        self.create_subscription(BeaconRanges, "beacons", self.readings.append, 100)
        self.create_subscription(Odometry, "ground_truth", lambda m: self.truth.__setitem__(stamp_ns(m), m), 100)

    def _on_pose(self, message: LocalizedPose) -> None:
        self.poses.append(message)
        if len(self.poses) < self.steps:
            command = TwistStamped()
            command.twist.linear.x, command.twist.angular.z = self.v, self.w
            self.cmd_vel.publish(command)

    def error(self, pose: LocalizedPose) -> tuple[float, float]:
        """(position m, heading rad) of a /pose against the ground truth at its stamp."""
        truth = self.truth[stamp_ns(pose)].pose.pose
        estimate = pose.pose.pose
        return (
            math.hypot(estimate.position.x - truth.position.x, estimate.position.y - truth.position.y),
            abs(float(wrap_angle(yaw_from_quaternion(estimate.orientation) - yaw_from_quaternion(truth.orientation)))),
        )
