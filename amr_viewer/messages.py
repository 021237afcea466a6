"""ROS messages to the plain data of amr_viewer.state, and the messages the viewer sends: no rclpy.

Readers take any object with the message's fields (a deserialized message, or a stand-in in a test).
"""

from __future__ import annotations

import math

import numpy as np

from amr_util.geometry import Pose2D, quaternion_from_yaw, yaw_from_quaternion
from amr_util.messages import path_points as path_points  # re-exported: the viewer's path reader
from amr_util.messages import scan_data
from amr_viewer.cdr import FrontiersData, PoseGraphData, Stamped, StampedTransform
from amr_viewer.geometry import finite
from amr_viewer.state import Estimate, MapImage, Scan, map_image

INITIAL_POSE_VARIANCE = (0.25, 0.25, 0.06853891945200942)
"""(x, y, yaw) variances RViz's 2D Pose Estimate sends: 0.5 m and pi / 12 rad standard deviations."""


def pose_of(pose) -> Pose2D:
    """A geometry_msgs/Pose in the plane."""
    q = pose.orientation
    return Pose2D(pose.position.x, pose.position.y, yaw_from_quaternion(q))


def occupancy_grid(message) -> MapImage:
    info = message.info
    return map_image(info.width, info.height, info.resolution, pose_of(info.origin), message.data)


def laser_scan(message) -> Scan:
    return Scan(scan_data(message), message.header.frame_id)


def localized_pose(message) -> Estimate:
    """amr_interfaces/LocalizedPose (a PoseWithCovariance and a `localized` flag)."""
    covariance = message.pose.covariance
    return Estimate(pose_of(message.pose.pose), (covariance[0], covariance[1], covariance[7]), bool(message.localized))


def stamped(header) -> Stamped:
    return Stamped(header.frame_id, header.stamp.sec + header.stamp.nanosec * 1e-9)


# -- the plain data of amr_viewer.cdr's readers, from deserialized messages (where the CDR fast path does not apply)


def tf_transforms(message) -> list[StampedTransform]:
    """tf2_msgs/TFMessage, as cdr.tf_message reads it."""
    return [
        StampedTransform(t.header.frame_id, t.child_frame_id, stamped(t.header).stamp, _transform_pose(t.transform))
        for t in message.transforms
    ]


def _transform_pose(transform) -> Pose2D:
    return Pose2D(transform.translation.x, transform.translation.y, yaw_from_quaternion(transform.rotation))


def odometry_transform(message) -> StampedTransform:
    """nav_msgs/Odometry, as cdr.odometry_pose reads it."""
    header = stamped(message.header)
    return StampedTransform(header.frame_id, message.child_frame_id, header.stamp, pose_of(message.pose.pose))


def pose_array(message) -> tuple[Stamped, np.ndarray]:
    """geometry_msgs/PoseArray, as cdr.pose_array reads it: header and an (N, 3) array of x, y, yaw."""
    poses = [pose_of(pose) for pose in message.poses]
    return stamped(message.header), np.array([(p.x, p.y, p.theta) for p in poses], dtype=float).reshape(-1, 3)


def pose_graph(message) -> PoseGraphData:
    """amr_interfaces/PoseGraph, as cdr.pose_graph reads it."""
    poses = np.array([(p.x, p.y, p.theta) for p in message.poses], dtype=float).reshape(-1, 3)
    return PoseGraphData(
        stamped(message.header),
        poses,
        np.asarray(message.edge_from, dtype=np.uint32),
        np.asarray(message.edge_to, dtype=np.uint32),
        np.asarray(message.loop_closure, dtype=bool),
    )


def frontiers(message) -> FrontiersData:
    """amr_interfaces/Frontiers, as cdr.frontiers reads it (centroids' z dropped)."""
    centroids = np.array([(p.x, p.y) for p in message.centroids], dtype=float).reshape(-1, 2)
    return FrontiersData(
        stamped(message.header),
        centroids,
        np.asarray(message.sizes, dtype=np.uint32),
        int(message.chosen),
        int(message.blacklisted),
        str(message.state),
    )


def beacon_positions(message) -> np.ndarray:
    """amr_interfaces/BeaconRanges' beacon positions as (B, 2)."""
    return np.array([(p.x, p.y) for p in message.beacons], dtype=float).reshape(-1, 2)


STATUS_FIELDS = (
    "sim_time",
    "steps",
    "collisions",
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


def simulator_status(message) -> dict:
    """amr_interfaces/SimulatorStatus as a dict of its fields."""
    return {name: getattr(message, name) for name in STATUS_FIELDS}


def fill_pose_stamped(message, frame_id: str, stamp, pose: Pose2D):
    """A geometry_msgs/PoseStamped (given empty) set to `pose` in `frame_id`; ValueError for a non-finite pose."""
    if not finite(*pose):
        raise ValueError(f"pose {tuple(pose)} is not finite")
    message.header.frame_id, message.header.stamp = frame_id, stamp
    _fill_pose(message.pose, pose)
    return message


def fill_initial_pose(message, frame_id: str, stamp, pose: Pose2D, variance=INITIAL_POSE_VARIANCE):
    """A geometry_msgs/PoseWithCovarianceStamped (given empty) as RViz's 2D Pose Estimate sends it."""
    if not finite(*pose):
        raise ValueError(f"pose {tuple(pose)} is not finite")
    message.header.frame_id, message.header.stamp = frame_id, stamp
    _fill_pose(message.pose.pose, pose)
    covariance = [0.0] * 36
    covariance[0], covariance[7], covariance[35] = variance
    message.pose.covariance = covariance
    return message


def _fill_pose(target, pose: Pose2D) -> None:
    target.position.x, target.position.y, target.position.z = float(pose.x), float(pose.y), 0.0
    qx, qy, qz, qw = quaternion_from_yaw(pose.theta)
    target.orientation.x, target.orientation.y, target.orientation.z, target.orientation.w = qx, qy, qz, qw


def format_status(status: dict) -> list[str]:
    """A simulator status as short lines for the status panel."""
    if not status:
        return []
    lines = [
        f"sim time {status['sim_time']:.2f} s (step {status['steps']}), {status['real_time_factor']:.1f}x real time",
        f"collisions {status['collisions']}"
        + (" (in contact)" if status["in_contact"] else "")
        + f", {status['distance_travelled']:.2f} m travelled"
        + (", goal reached" if status["goal_reached"] else ""),
    ]
    if status["localization_enabled"]:
        error = status["position_error"]
        judged = f", error {100 * error:.1f} cm" if math.isfinite(error) else ""
        lines.append(("localized" if status["localized"] else "not localized") + judged)
    return lines
