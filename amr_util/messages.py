"""Message helpers the nodes share: a LaserScan as the scan readers take it, /cmd_vel, yaw quaternions, a planar
transform on /tf.

Plain functions of message types (no rclpy), so that nodes stay thin shells and tests need no node.
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Quaternion, TransformStamped, Twist, TwistStamped
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from amr_util.geometry import quaternion_from_yaw
from amr_util.scan import ScanData


def scan_data(message: LaserScan) -> ScanData:
    """The ranges and geometry of a LaserScan as the scan readers (controllers, localizers) take them."""
    return ScanData(
        np.asarray(message.ranges, dtype=float),
        message.angle_min,
        message.angle_increment,
        message.range_min,
        message.range_max,
    )


def quaternion(theta: float) -> Quaternion:
    """geometry_msgs/Quaternion of the rotation theta about z (amr_util.geometry.yaw_from_quaternion's inverse)."""
    x, y, z, w = quaternion_from_yaw(theta)
    return Quaternion(x=x, y=y, z=z, w=w)


def transform(stamp: Time, parent: str, child: str, pose) -> TFMessage:
    """One planar transform parent -> child (the child's pose (x, y, theta) in the parent) on /tf: what a
    localizer or SLAM broadcasts as map -> odom."""
    message = TransformStamped()
    message.header.stamp, message.header.frame_id = stamp, parent
    message.child_frame_id = child
    message.transform.translation.x, message.transform.translation.y = float(pose[0]), float(pose[1])
    message.transform.rotation = quaternion(float(pose[2]))
    return TFMessage(transforms=[message])


def velocity_command(
    v: float, w: float, *, stamped: bool, flip_angular_sign: bool, stamp: Time, frame_id: str = "base_footprint"
) -> Twist | TwistStamped:
    """TwistStamped (Jazzy's /cmd_vel) or plain Twist (a real TurtleBot3's bringup); a non-finite command
    becomes a stop, never a NaN on the wire; `flip_angular_sign` is seed 002's real robot (5.2.1)."""
    if not (math.isfinite(v) and math.isfinite(w)):
        v = w = 0.0
    if flip_angular_sign:
        w = -w
    if stamped:
        message = TwistStamped()
        message.header.stamp, message.header.frame_id = stamp, frame_id
        twist = message.twist
    else:
        message = twist = Twist()
    twist.linear.x, twist.angular.z = float(v), float(w)
    return message


def path_points(message) -> np.ndarray:
    """(N, 2) positions of a nav_msgs/Path."""
    return np.array([(p.pose.position.x, p.pose.position.y) for p in message.poses], dtype=float).reshape(-1, 2)
