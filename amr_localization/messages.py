"""Localizer state <-> ROS messages: plain functions, so the nodes stay thin shells (no rclpy here).

Planar poses: yaw theta is the quaternion (w, x, y, z) = (cos(theta/2), 0, 0, sin(theta/2)); a 3x3
covariance over (x, y, theta) fills the 6x6 one of geometry_msgs/PoseWithCovariance at rows and
columns (0, 1, 5) (x, y, yaw), the others left 0.
"""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseArray, PoseWithCovariance
from nav_msgs.msg import Odometry

from amr_interfaces.msg import BeaconRanges, LocalizedPose, LocalizerStatus
from amr_localization.beacons import BeaconReading, same_beacons
from amr_localization.errors import LocalizationError
from amr_localization.particle_filter import FilterStatus
from amr_localization.pose_estimate import PoseEstimate
from amr_util.geometry import yaw_from_quaternion
from amr_util.messages import quaternion

PLANAR_AXES = (0, 1, 5)
"""x, y, yaw in the row-major 6x6 covariance of PoseWithCovariance."""


def odometry_pose(message: Odometry) -> tuple[float, float, float]:
    """(x, y, theta) of the robot in the odometry frame."""
    pose = message.pose.pose
    return float(pose.position.x), float(pose.position.y), yaw_from_quaternion(pose.orientation)


def beacon_positions(message: BeaconRanges) -> np.ndarray:
    """(B, 2) beacon positions of an amr_interfaces/BeaconRanges, unchecked (beacons.checked_beacons checks)."""
    return np.array([[b.x, b.y] for b in message.beacons], dtype=float).reshape(-1, 2)


def beacon_reading(message: BeaconRanges, positions: np.ndarray) -> BeaconReading:
    """The ranges and compass of a BeaconRanges measured to `positions` (the filter's beacons, in their order);
    raises LocalizationError naming the problem: other positions, a wrong count, a NaN or negative range."""
    same_beacons(positions, beacon_positions(message))
    return BeaconReading.checked(list(message.ranges), message.compass, len(positions))


def pose_with_covariance(x: float, y: float, theta: float, covariance: np.ndarray) -> PoseWithCovariance:
    message = PoseWithCovariance()
    message.pose.position.x, message.pose.position.y = float(x), float(y)
    message.pose.orientation = quaternion(theta)
    full = np.zeros((6, 6))
    full[np.ix_(PLANAR_AXES, PLANAR_AXES)] = covariance
    message.covariance = [float(v) for v in full.ravel()]
    return message


def planar_covariance(message: PoseWithCovariance) -> np.ndarray:
    """The 3x3 (x, y, yaw) block of a PoseWithCovariance's covariance."""
    full = np.asarray(message.covariance, dtype=float).reshape(6, 6)
    return full[np.ix_(PLANAR_AXES, PLANAR_AXES)]


def initial_pose(message: PoseWithCovariance) -> tuple[float, float, float, np.ndarray | None]:
    """(x, y, theta, 3x3 covariance or None when all zero) of an /initialpose; raises on NaN or a bad quaternion."""
    q = message.pose.orientation
    values = (message.pose.position.x, message.pose.position.y, q.w, q.x, q.y, q.z)
    if not all(map(math.isfinite, values)):
        raise LocalizationError(f"initial pose: position and orientation must be finite, got {values}")
    if abs(math.sqrt(q.w**2 + q.x**2 + q.y**2 + q.z**2) - 1.0) > 1e-3:
        raise LocalizationError("initial pose: the orientation is not a unit quaternion")
    covariance = planar_covariance(message)
    return (
        float(message.pose.position.x),
        float(message.pose.position.y),
        yaw_from_quaternion(q),
        None if not covariance.any() else covariance,
    )


def is_finite(estimate: PoseEstimate) -> bool:
    return all(map(math.isfinite, (estimate.x, estimate.y, estimate.theta))) and bool(
        np.isfinite(estimate.covariance).all()
    )


def localized_pose(
    stamp: Time, frame: str, estimate: PoseEstimate, localized: bool, confidence: float = 0.0, runner_up: float = 0.0
) -> LocalizedPose:
    """/pose: the estimate, its covariance, localized, and the best and second best places' probabilities."""
    message = LocalizedPose(
        localized=bool(localized), confidence=_probability(confidence), runner_up_confidence=_probability(runner_up)
    )
    message.header.stamp, message.header.frame_id = stamp, frame
    message.pose = pose_with_covariance(estimate.x, estimate.y, estimate.theta, estimate.covariance)
    return message


def particle_cloud(stamp: Time, frame: str, particles: np.ndarray) -> PoseArray:
    message = PoseArray()
    message.header.stamp, message.header.frame_id = stamp, frame
    half = 0.5 * particles[:, 2]
    cos, sin = np.cos(half), np.sin(half)
    message.poses = [Pose() for _ in range(len(particles))]
    for pose, (x, y, _), w, z in zip(message.poses, particles, cos, sin, strict=True):
        pose.position.x, pose.position.y = float(x), float(y)
        pose.orientation.w, pose.orientation.z = float(w), float(z)
    return message


def localizer_status(status: FilterStatus, localized: bool) -> LocalizerStatus:
    """The filter's status (header left for the publisher to stamp)."""
    return LocalizerStatus(
        particles=status.particles,
        clusters=status.clusters,
        effective_sample_size=float(status.effective_sample_size),
        confidence=_probability(status.confidence),
        runner_up_confidence=_probability(status.runner_up),
        beams=float(status.beams),
        scan_weight=_probability(status.scan_weight),
        injected=status.injected,
        updated=status.updated,
        update_time=float(status.update_time),
        localized=bool(localized),
        event=status.event,
    )


def _probability(value: float) -> float:
    """A probability for a message: in [0, 1], 0 for anything non-finite (nothing non-finite is published)."""
    value = float(value)
    return min(max(value, 0.0), 1.0) if math.isfinite(value) else 0.0
