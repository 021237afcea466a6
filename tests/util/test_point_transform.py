"""amr_util.geometry's point transform against the homogeneous matrix of the pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_util.geometry import Pose2D, transform_points

RNG = np.random.default_rng(21)


def test_points_are_placed_by_a_pose_as_its_matrix_does():
    for _ in range(20):
        pose = Pose2D(*RNG.uniform(-5, 5, 2), RNG.uniform(-math.pi, math.pi))
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        matrix = np.array([[c, -s, pose.x], [s, c, pose.y], [0, 0, 1]])
        points = RNG.uniform(-1, 1, (5, 2))
        expected = (matrix @ np.column_stack([points, np.ones(5)]).T).T[:, :2]
        assert transform_points(pose, points) == pytest.approx(expected)
        assert transform_points(tuple(pose), points) == pytest.approx(expected)  # any (x, y, theta)
