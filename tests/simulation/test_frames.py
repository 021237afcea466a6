"""Planar frame arithmetic behind /tf: composition, inverse, and the ground-truth map -> odom."""

import math

import numpy as np
import pytest

from amr_simulation import messages
from amr_util.geometry import Pose2D, compose, inverse, map_to_odom, wrap_angle
from amr_util.stamps import stamp_from_seconds

RNG = np.random.default_rng(11)
POSES = [Pose2D(*RNG.uniform(-5.0, 5.0, 2), float(RNG.uniform(-math.pi, math.pi))) for _ in range(40)]


def close(a: Pose2D, b: Pose2D, tol: float = 1e-9) -> bool:
    return math.hypot(a.x - b.x, a.y - b.y) < tol and abs(wrap_angle(a.theta - b.theta)) < tol


def matrix(p: Pose2D) -> np.ndarray:
    c, s = math.cos(p.theta), math.sin(p.theta)
    return np.array([[c, -s, p.x], [s, c, p.y], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("a, b", list(zip(POSES, POSES[::-1], strict=True)))
def test_compose_is_the_product_of_homogeneous_matrices(a, b):
    product = matrix(a) @ matrix(b)
    c = compose(a, b)
    assert np.allclose(matrix(c), product, atol=1e-12)


@pytest.mark.parametrize("a", POSES[:10])
def test_inverse_composes_to_identity_both_ways(a):
    assert close(compose(a, inverse(a)), Pose2D(0.0, 0.0, 0.0))
    assert close(compose(inverse(a), a), Pose2D(0.0, 0.0, 0.0))


@pytest.mark.parametrize("truth, odom", list(zip(POSES[:20], POSES[20:], strict=True)))
def test_map_to_odom_composed_with_odometry_is_the_true_pose(truth, odom):
    assert close(compose(map_to_odom(truth, odom), odom), truth)


def test_transform_message_carries_the_pose_as_translation_and_yaw_quaternion():
    message = messages.transform(stamp_from_seconds(1.25), "odom", "base_footprint", Pose2D(1.0, -2.0, 2.5))
    assert (message.header.frame_id, message.child_frame_id) == ("odom", "base_footprint")
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (1, 250_000_000)
    t, q = message.transform.translation, message.transform.rotation
    assert (t.x, t.y, t.z) == (1.0, -2.0, 0.0)
    assert 2.0 * math.atan2(q.z, q.w) == pytest.approx(2.5) and q.x == q.y == 0.0
    assert math.hypot(q.w, q.z) == pytest.approx(1.0)


def test_a_robots_transforms_are_odom_to_base_then_map_to_odom_as_asked():
    class Robot:
        pose, odom_pose = Pose2D(1.0, 2.0, 0.5), Pose2D(0.9, 2.1, 0.4)

    frames = {"odom": "r1/odom", "base": "r1/base_footprint", "world": "map"}
    both = messages.robot_transforms(Robot(), frames, True, True)
    assert [(parent, child) for parent, child, _ in both] == [("r1/odom", "r1/base_footprint"), ("map", "r1/odom")]
    assert both[0][2] == Robot.odom_pose and both[1][2] == map_to_odom(Robot.pose, Robot.odom_pose)
    assert compose(both[1][2], both[0][2]) == pytest.approx(Robot.pose), "map -> odom -> base is the truth"
    assert [part[:2] for part in messages.robot_transforms(Robot(), frames, False, True)] == [("map", "r1/odom")]
    assert messages.robot_transforms(Robot(), frames, False, False) == []


def test_a_goal_is_its_regions_centre_heading_zero():
    class Goal:
        x, y, radius = 1.5, -1.25, 0.2

    goal = messages.goal_pose(stamp_from_seconds(2.5), "map", Goal())
    assert (goal.header.frame_id, goal.header.stamp.sec, goal.header.stamp.nanosec) == ("map", 2, 500_000_000)
    assert (goal.pose.position.x, goal.pose.position.y, goal.pose.orientation.w) == (1.5, -1.25, 1.0)
