"""amr_util.wire: a serialized message rewritten in place deserializes to the message with the same values set."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from amr_interfaces.msg import SimulatorStatus
from amr_util.wire import WireMessage


def _set(message, path: str, value) -> None:
    parts = path.split(".")
    for part in parts[:-1]:
        message = message[int(part)] if part.isdigit() else getattr(message, part)
    setattr(message, parts[-1], value)


def _same(data: bytes, message) -> bool:
    """`data` is what rclpy would have sent for `message` (compared as received, after deserializing)."""
    kind = type(message)
    return deserialize_message(data, kind) == deserialize_message(serialize_message(message), kind)


ODOMETRY = (
    "header.stamp.sec",
    "header.stamp.nanosec",
    "pose.pose.position.x",
    "pose.pose.position.y",
    "pose.pose.orientation.z",
    "pose.pose.orientation.w",
    "twist.twist.linear.x",
    "twist.twist.angular.z",
)


@pytest.mark.parametrize("seed", range(5))
def test_odometry_rewritten_in_place_is_the_odometry_with_those_values(seed):
    rng = np.random.default_rng(seed)
    template = Odometry()
    template.header.frame_id, template.child_frame_id = "r2/odom" * (seed + 1), "r2/base_footprint"
    template.pose.covariance[0] = 0.25  # a field not rewritten keeps the template's value
    wire = WireMessage(template, ODOMETRY)
    for _ in range(3):  # the same wire again and again: nothing of the last values remains
        values = [int(rng.integers(0, 2**31 - 1)), int(rng.integers(0, 10**9)), *map(float, rng.normal(size=6))]
        expected = Odometry()
        expected.header.frame_id, expected.child_frame_id = template.header.frame_id, template.child_frame_id
        expected.pose.covariance[0] = 0.25
        for path, value in zip(ODOMETRY, values, strict=True):
            _set(expected, path, value)
        assert _same(wire.fill(*values), expected)


def test_a_scan_takes_its_whole_ranges_with_infinities_and_keeps_its_geometry():
    template = LaserScan(
        angle_min=-math.pi,
        angle_max=math.pi,
        angle_increment=2 * math.pi / 240,
        range_min=0.12,
        range_max=3.5,
        scan_time=0.05,
        ranges=[1.0] * 240,
    )
    template.header.frame_id = "base_scan"
    wire = WireMessage(template, ("header.stamp.sec", "header.stamp.nanosec", "ranges"))
    ranges = np.random.default_rng(1).uniform(0.12, 3.5, 240)
    ranges[[0, 17, 239]] = [math.inf, -math.inf, math.nan]
    data = wire.fill(12, 500_000_000, ranges)
    received = deserialize_message(data, LaserScan)
    np.testing.assert_array_equal(np.asarray(received.ranges), ranges.astype(np.float32))
    assert (received.header.stamp.sec, received.header.stamp.nanosec) == (12, 500_000_000)
    assert (received.header.frame_id, received.range_max, len(received.intensities)) == (
        "base_scan",
        pytest.approx(3.5),
        0,
    )
    with pytest.raises(ValueError, match="239 values for a sequence of 240"):
        wire.fill(12, 0, ranges[:-1])


def test_every_transform_of_a_tf_message_and_every_status_field():
    transforms = [TransformStamped() for _ in range(3)]
    for i, transform in enumerate(transforms):
        transform.header.frame_id, transform.child_frame_id = "map", f"r{i}/odom"
    fields = [
        f"transforms.{i}.{name}"
        for i in range(3)
        for name in ("header.stamp.sec", "transform.translation.x", "transform.rotation.z", "transform.rotation.w")
    ]
    values = [7, 1.5, 0.25, 0.96, 8, -2.0, -0.5, 0.86, 9, 3.25, 1.0, 0.0]
    expected = TFMessage(transforms=transforms)
    wire = WireMessage(
        TFMessage(transforms=[TransformStamped(header=t.header, child_frame_id=t.child_frame_id) for t in transforms]),
        fields,
    )
    for path, value in zip(fields, values, strict=True):
        _set(expected, path, value)
    assert _same(wire.fill(*values), expected)

    names = ("sim_time", "steps", "collisions", "in_contact", "goal_reached", "localized", "position_error")
    status = SimulatorStatus(robot="r2")
    wire = WireMessage(status, names)
    values = (12.35, 2**40 + 3, 4, True, False, True, math.nan)
    received = deserialize_message(wire.fill(*values), SimulatorStatus)
    assert received.robot == "r2"
    assert [getattr(received, name) for name in names[:-1]] == list(values[:-1])
    assert math.isnan(received.position_error)


def test_what_cannot_be_rewritten_in_place_is_refused_by_name():
    with pytest.raises(ValueError, match="header.frame_id is a string"):
        WireMessage(Odometry(), ("header.frame_id",))
    with pytest.raises(ValueError, match="Odometry has no field 'speed'"):
        WireMessage(Odometry(), ("speed",))
    with pytest.raises(ValueError, match="ranges: an empty sequence"):
        WireMessage(LaserScan(), ("ranges",))
