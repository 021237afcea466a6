"""Simulator state -> ROS messages: plain functions, so the node stays a thin shell.

Poses are planar; a yaw theta is the quaternion (w, x, y, z) = (cos(theta/2), 0, 0, sin(theta/2)).
"""

from __future__ import annotations

import array
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseStamped, TransformStamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from amr_interfaces.msg import BeaconRanges, SimulatorStatus
from amr_simulation.config import BeaconConfig, LidarConfig
from amr_util.geometry import Pose2D, map_to_odom, quaternion_from_yaw

if TYPE_CHECKING:
    from amr_simulation.fleet import Fleet, SimulatedRobot


def clock(time: Time) -> Clock:
    return Clock(clock=time)


def transform(time: Time, parent: str, child: str, pose: Pose2D) -> TransformStamped:
    """geometry_msgs/TransformStamped placing frame `child` at `pose` in frame `parent` (tf2's convention)."""
    message = TransformStamped()
    message.header.stamp = time
    message.header.frame_id = parent
    message.child_frame_id = child
    translation = message.transform.translation
    translation.x, translation.y = pose.x, pose.y
    rotation = message.transform.rotation
    rotation.x, rotation.y, rotation.z, rotation.w = quaternion_from_yaw(pose.theta)
    return message


def tf_message(transforms: Sequence[TransformStamped]) -> TFMessage:
    """tf2_msgs/TFMessage, what /tf and /tf_static carry."""
    return TFMessage(transforms=list(transforms))


def odometry(time: Time, frame: str, child_frame: str, pose: Pose2D, twist: Sequence[float]) -> Odometry:
    """nav_msgs/Odometry: pose in `frame`, twist (vx, vy, w) in `child_frame` (the body)."""
    message = Odometry()
    message.header.stamp = time
    message.header.frame_id = frame
    message.child_frame_id = child_frame
    position = message.pose.pose.position
    position.x, position.y = pose.x, pose.y
    orientation = message.pose.pose.orientation
    orientation.x, orientation.y, orientation.z, orientation.w = quaternion_from_yaw(pose.theta)
    vx, vy, w = twist
    message.twist.twist.linear.x, message.twist.twist.linear.y = vx, vy
    message.twist.twist.angular.z = w
    return message


def laser_scan(time: Time, frame: str, ranges: np.ndarray, lidar: LidarConfig, scan_time: float) -> LaserScan:
    """sensor_msgs/LaserScan of one scan taken at once (time_increment 0); +-inf kept (REP 117)."""
    message = LaserScan()
    message.header.stamp = time
    message.header.frame_id = frame
    message.angle_min = lidar.angle_min
    message.angle_max = lidar.angle_max
    message.angle_increment = lidar.angle_increment
    message.scan_time = scan_time
    message.range_min = lidar.range_min
    message.range_max = lidar.range_max
    message.ranges = array.array("f", np.asarray(ranges, dtype=np.float32).tobytes())
    return message


STATUS_FIELDS = (
    "sim_time",
    "steps",
    "collisions",
    "wall_collisions",
    "robot_collisions",
    "in_contact",
    "goal_reached",
    "distance_travelled",
    "real_time_factor",
    "localization_enabled",
    "localized",
    "first_localized_time",
    "position_error",
    "heading_error",
)
"""The SimulatorStatus fields that change from step to step (all but the header and the robot's name)."""

ODOMETRY_WIRE = (
    "header.stamp.sec",
    "header.stamp.nanosec",
    "pose.pose.position.x",
    "pose.pose.position.y",
    "pose.pose.orientation.x",
    "pose.pose.orientation.y",
    "pose.pose.orientation.z",
    "pose.pose.orientation.w",
    "twist.twist.linear.x",
    "twist.twist.linear.y",
    "twist.twist.angular.z",
)
SCAN_WIRE = ("header.stamp.sec", "header.stamp.nanosec", "ranges")
TRANSFORM_WIRE = (
    "header.stamp.sec",
    "header.stamp.nanosec",
    "transform.translation.x",
    "transform.translation.y",
    "transform.rotation.x",
    "transform.rotation.y",
    "transform.rotation.z",
    "transform.rotation.w",
)
STATUS_WIRE = ("header.stamp.sec", "header.stamp.nanosec", *STATUS_FIELDS)
"""What changes from one observation to the next in each message the simulator node keeps serialized
(amr_util.wire; the rest: frames, names, geometry, stays)."""


def status_fields(
    fleet: Fleet, robot: SimulatedRobot, distance: float, real_time_factor: float, localization=None
) -> dict:
    """SimulatorStatus's changing fields (STATUS_FIELDS) of one robot of a fleet; `localization` is the robot's
    LocalizationCheck state (None: the check is off, or no /pose yet)."""
    return dict(
        sim_time=float(fleet.time),
        steps=fleet.steps,
        collisions=robot.collisions,
        wall_collisions=robot.wall_collisions,
        robot_collisions=sum(robot.robot_collisions.values()),
        in_contact=bool(robot.in_contact),
        goal_reached=bool(robot.goal_reached),
        distance_travelled=float(distance),
        real_time_factor=float(real_time_factor),
        localization_enabled=localization is not False,
        localized=bool(localization and localization.localized),
        first_localized_time=localization.first_localized_time if localization else -1.0,
        position_error=localization.position_error if localization else math.nan,
        heading_error=localization.heading_error if localization else math.nan,
    )


def status(
    time: Time,
    frame: str,
    fleet: Fleet,
    robot: SimulatedRobot,
    distance: float,
    real_time_factor: float,
    localization=False,
) -> SimulatorStatus:
    """amr_interfaces/SimulatorStatus of one robot of a fleet (the one robot of a Simulator's fleet: robot "");
    distance and real-time factor are the node's; `localization`: False without the localization check, else the
    check's state (None before the first /pose)."""
    message = SimulatorStatus(robot=robot.name, **status_fields(fleet, robot, distance, real_time_factor, localization))
    message.header.stamp = time
    message.header.frame_id = frame
    return message


def beacon_ranges(
    time: Time, frame: str, positions: np.ndarray, ranges: np.ndarray, compass: float, noise: BeaconConfig
) -> BeaconRanges:
    """amr_interfaces/BeaconRanges: beacon i at positions[i] measured at ranges[i] (the world's order)."""
    message = BeaconRanges(
        beacons=[Point(x=float(x), y=float(y)) for x, y in positions],
        ranges=[float(r) for r in ranges],
        compass=float(compass),
        range_noise_std=noise.range_noise_std,
        compass_noise_std=noise.compass_noise_std,
    )
    message.header.stamp = time
    message.header.frame_id = frame
    return message


def robot_transforms(
    robot: SimulatedRobot, frames: dict[str, str], odom_to_base: bool, map_to_odom_wanted: bool
) -> list[tuple[str, str, Pose2D]]:
    """A robot's transforms as (parent, child, pose) in its `frames` (odom, base, world): odom -> base from the
    encoder odometry and, when asked, the ground-truth map -> odom."""
    parts = []
    if odom_to_base:
        parts.append((frames["odom"], frames["base"], robot.odom_pose))
    if map_to_odom_wanted:
        parts.append((frames["world"], frames["odom"], map_to_odom(robot.pose, robot.odom_pose)))
    return parts


def goal_pose(time: Time, frame: str, goal) -> PoseStamped:
    """geometry_msgs/PoseStamped at a goal region's centre (x, y), heading 0, for a navigator to take as its goal."""
    message = PoseStamped()
    message.header.stamp, message.header.frame_id = time, frame
    message.pose.position.x, message.pose.position.y = goal.x, goal.y
    message.pose.orientation.w = 1.0
    return message
