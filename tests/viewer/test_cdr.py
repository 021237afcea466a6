"""The viewer's CDR readers against rclpy's own serialization, for varied frame names (alignment) and sizes."""

import math

import numpy as np
import pytest
from geometry_msgs.msg import Pose as PoseMessage
from geometry_msgs.msg import PoseArray, TransformStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from tf2_msgs.msg import TFMessage

from amr_util.geometry import quaternion_from_yaw as quaternion_of
from amr_viewer import cdr

RNG = np.random.default_rng(7)
NAMES = ["", "m", "map", "odom", "base_footprint", "robot_12/base_scan", "a" * 37]


def stamp(message, seconds: float) -> None:
    message.header.stamp.sec = int(seconds)
    message.header.stamp.nanosec = int(round((seconds % 1) * 1e9))


@pytest.mark.parametrize("count", [0, 1, 2, 5])
def test_tf_message(count):
    message, expected = TFMessage(), []
    for _ in range(count):
        parent, child = RNG.choice(NAMES, 2)
        x, y, yaw, t = *RNG.uniform(-10, 10, 2), RNG.uniform(-math.pi, math.pi), RNG.uniform(0, 1e5)
        transform = TransformStamped()
        stamp(transform, t)
        transform.header.frame_id, transform.child_frame_id = str(parent), str(child)
        transform.transform.translation.x, transform.transform.translation.y = x, y
        transform.transform.translation.z = RNG.uniform(-1, 1)
        q = transform.transform.rotation
        q.x, q.y, q.z, q.w = quaternion_of(yaw)
        message.transforms.append(transform)
        expected.append((str(parent), str(child), t, x, y, yaw))
    parsed = cdr.tf_message(serialize_message(message))
    assert [(p.parent, p.child) for p in parsed] == [e[:2] for e in expected]
    for p, e in zip(parsed, expected, strict=True):
        assert (p.stamp, *p.pose) == pytest.approx(e[2:], abs=1e-6)


@pytest.mark.parametrize("frame,child", [("map", "base_footprint"), ("", ""), ("odom_long_name", "b")])
def test_odometry_pose(frame, child):
    message = Odometry()
    message.header.frame_id, message.child_frame_id = frame, child
    stamp(message, 12.5)
    message.pose.pose.position.x, message.pose.pose.position.y = 1.25, -3.5
    q = message.pose.pose.orientation
    q.x, q.y, q.z, q.w = quaternion_of(2.0)
    message.pose.covariance = list(RNG.uniform(0, 1, 36))
    message.twist.twist.linear.x = 0.2
    parsed = cdr.odometry_pose(serialize_message(message))
    assert (parsed.parent, parsed.child) == (frame, child)
    assert (parsed.stamp, *parsed.pose) == pytest.approx((12.5, 1.25, -3.5, 2.0))


@pytest.mark.parametrize("count,frame", [(0, "map"), (1, "map"), (5000, "map"), (3, "odd_frame")])
def test_pose_array_as_one_array(count, frame):
    message = PoseArray()
    message.header.frame_id = frame
    poses = np.column_stack([RNG.uniform(-5, 5, (count, 2)), RNG.uniform(-math.pi, math.pi, count)])
    for x, y, yaw in poses:
        pose = PoseMessage()
        pose.position.x, pose.position.y = float(x), float(y)
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = quaternion_of(yaw)
        message.poses.append(pose)
    header, parsed = cdr.pose_array(serialize_message(message))
    assert header.frame_id == frame and parsed.shape == (count, 3)
    assert parsed == pytest.approx(poses, abs=1e-9)


def test_malformed_bytes_are_refused_with_a_reason():
    data = serialize_message(PoseArray(poses=[PoseMessage()] * 3))
    with pytest.raises(cdr.CdrError, match="ends early"):
        cdr.pose_array(data[:-10])
    with pytest.raises(cdr.CdrError, match="encapsulation"):
        cdr.tf_message(b"\x07\x07\x00\x00abc")
    with pytest.raises(cdr.CdrError):
        cdr.odometry_pose(b"")
