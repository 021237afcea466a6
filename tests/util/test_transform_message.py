"""amr_util.messages.transform: the one planar transform -> TFMessage helper (the particle filter's and slam's)."""

import math

from builtin_interfaces.msg import Time

from amr_util.geometry import yaw_from_quaternion
from amr_util.messages import transform


def test_transform_carries_frames_stamp_and_planar_pose():
    message = transform(Time(sec=3, nanosec=5), "map", "odom", (1.5, -2.0, 2.5))
    assert len(message.transforms) == 1
    item = message.transforms[0]
    assert (item.header.frame_id, item.child_frame_id) == ("map", "odom")
    assert (item.header.stamp.sec, item.header.stamp.nanosec) == (3, 5)
    assert (item.transform.translation.x, item.transform.translation.y, item.transform.translation.z) == (
        1.5,
        -2.0,
        0.0,
    )
    assert math.isclose(yaw_from_quaternion(item.transform.rotation), 2.5, abs_tol=1e-12)


def test_localization_and_slam_use_the_same_helper():
    from amr_localization import localizer_node
    from amr_mapping import slam_node

    assert localizer_node.transform is transform and slam_node.transform is transform
