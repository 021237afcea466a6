"""amr_planning.messages.path_message: one pose per point, each heading along the path."""

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time

from amr_planning.messages import path_message
from amr_util.geometry import yaw_from_quaternion


@pytest.mark.parametrize("count", [0, 1, 2, 4])
def test_one_pose_per_point_heading_along_the_path(count):
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])[:count]
    message = path_message(points, "map", Time(sec=3))
    assert message.header.frame_id == "map" and message.header.stamp.sec == 3
    assert [(p.pose.position.x, p.pose.position.y) for p in message.poses] == [tuple(p) for p in points]
    yaws = [yaw_from_quaternion(p.pose.orientation) for p in message.poses]
    expected = {0: [], 1: [0.0], 2: [0.0, 0.0], 4: [0.0, math.pi / 2, math.pi, math.pi]}[count]
    assert yaws == pytest.approx(expected)
