"""amr_util.geometry's point transform against the homogeneous matrix of the pose, and its one-point-per-cell filter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_util.geometry import Pose2D, one_per_cell, transform_points

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


def test_one_per_cell_keeps_the_first_point_of_each_cell_in_order():
    points = np.array([[0.01, 0.01], [0.5, 0.5], [0.02, 0.03], [0.12, 0.0], [0.55, 0.52]])
    np.testing.assert_array_equal(one_per_cell(points, 0.1), points[[0, 1, 3]])


def test_one_per_cell_matches_a_voxel_filter_by_rows_on_any_box():
    for scale in (0.3, 40.0):
        points = RNG.uniform(-scale, scale, (500, 2))
        points = np.concatenate([points, points[:200] + 1e-4, points[:0]])  # second points in the same cells
        cells = np.floor(points / 0.05).astype(np.int64)
        _, first = np.unique(cells, axis=0, return_index=True)
        np.testing.assert_array_equal(one_per_cell(points, 0.05), points[np.sort(first)])
    assert one_per_cell(np.zeros((0, 2)), 0.05).shape == (0, 2)
