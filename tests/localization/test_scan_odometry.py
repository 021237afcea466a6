"""Scan-matched odometry (amr_localization.scan_odometry): the window's scans placed by matching and odometry."""

from __future__ import annotations

import math

import numpy as np

from amr_localization.motion_model import OdometryNoise, motion_covariance
from amr_localization.scan_odometry import matched_increment
from amr_util.geometry import relative_pose, transform_points, wrap_angle


def wall_points(segments, step=0.02) -> np.ndarray:
    """Points along wall segments [(x0, y0, x1, y1), ...], `step` m apart, in the world frame."""
    clouds = []
    for x0, y0, x1, y1 in segments:
        count = max(2, int(math.hypot(x1 - x0, y1 - y0) / step))
        t = np.linspace(0.0, 1.0, count)
        clouds.append(np.column_stack([x0 + t * (x1 - x0), y0 + t * (y1 - y0)]))
    return np.concatenate(clouds)


ROOM = wall_points([(0, 0, 8, 0), (8, 0, 8, 5), (8, 5, 0, 5), (0, 5, 0, 0), (3, 2, 4, 2), (4, 2, 4, 3.5)])
CORRIDOR = wall_points([(-20, -1, 20, -1), (-20, 1, 20, 1)])


def seen_from(points: np.ndarray, pose) -> np.ndarray:
    """The world points in the robot frame at pose, within 8 m."""
    local = transform_points(relative_pose(pose, (0.0, 0.0, 0.0)), points)
    return local[np.hypot(local[:, 0], local[:, 1]) <= 8.0]


def test_a_drifted_odometry_increment_is_corrected_by_the_match():
    first, second = np.array([1.5, 1.0, 0.2]), np.array([2.5, 1.3, 0.35])
    truth = np.array(relative_pose(first, second))
    drifted = truth + [0.12, -0.08, math.radians(6.0)]  # the odometry's increment, off by 14 cm and 6 deg
    noise = OdometryNoise(0.01, 0.01, 0.01, 0.01)  # the filter's: sigma 0.1 m and 0.1 rad over 1 m
    covariance = motion_covariance(drifted, noise)
    found = matched_increment(seen_from(ROOM, first), seen_from(ROOM, second), drifted, covariance, 0.05, 0.25)
    assert math.hypot(*(found[:2] - truth[:2])) < 0.03
    assert abs(wrap_angle(found[2] - truth[2])) < math.radians(1.0)


def test_along_a_corridor_the_odometry_decides_and_across_it_the_match():
    first, second = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    truth = np.array(relative_pose(first, second))
    drifted = truth + [0.1, 0.1, 0.0]  # 10 cm too far along the corridor and 10 cm across it
    noise = OdometryNoise(0.01, 0.01, 0.01, 0.01)
    covariance = motion_covariance(drifted, noise)
    found = matched_increment(seen_from(CORRIDOR, first), seen_from(CORRIDOR, second), drifted, covariance, 0.05, 0.25)
    assert abs(found[1] - truth[1]) < 0.03  # across: the walls say where
    assert abs(found[0] - drifted[0]) < 0.05  # along: the walls say nothing, the odometry stays


def test_a_motion_too_small_to_move_a_point_by_a_cell_is_the_odometry_increment():
    pose = np.array([2.0, 2.0, 0.0])
    prior = np.array([0.01, 0.0, 0.001])
    covariance = motion_covariance(prior, OdometryNoise(0.01, 0.01, 0.01, 0.01))
    found = matched_increment(seen_from(ROOM, pose), seen_from(ROOM, pose + prior), prior, covariance, 0.05, 0.25)
    np.testing.assert_array_equal(found, prior)


def test_too_few_points_leave_the_odometry_increment():
    prior = np.array([1.0, 0.0, 0.1])
    found = matched_increment(ROOM[:5], ROOM[:5], prior, np.diag([0.01, 0.01, 0.01]), 0.05, 0.25)
    np.testing.assert_array_equal(found, prior)


def seen_in_view(points: np.ndarray, pose, reach: float, field_of_view: float) -> np.ndarray:
    """The world points in the robot frame at pose, within `reach` and the scanner's field of view (rad, centred
    ahead)."""
    local = seen_from(points, pose)
    bearing = np.arctan2(local[:, 1], local[:, 0])
    return local[(np.hypot(local[:, 0], local[:, 1]) <= reach) & (np.abs(bearing) <= 0.5 * field_of_view)]


HALL = wall_points(
    [
        (0, 0, 12, 0),
        (12, 0, 12, 6),
        (12, 6, 0, 6),
        (0, 6, 0, 0),
        (3, 2, 4, 2),
        (4, 2, 4, 3.5),
        (8, 4, 9.5, 4),
        (8, 1, 8, 2.5),
        (6, 5, 6, 6),
    ]
)


def placed_by_a_half_circle_scanner(first, second, drifted) -> np.ndarray:
    """The increment from `first` to `second` (world poses in HALL) that matched_increment finds from a 180-degree
    scanner's end points within 8 m, the odometry's increment `drifted` with 5 % motion noise."""
    truth = np.array(relative_pose(first, second))
    covariance = motion_covariance(truth, OdometryNoise(0.05, 0.05, 0.05, 0.05))
    return matched_increment(
        seen_in_view(HALL, first, 8.0, math.pi),
        seen_in_view(HALL, second, 8.0, math.pi),
        drifted,
        covariance,
        0.05,
        0.25,
    )


def test_a_keyframe_metres_away_is_placed_though_the_window_could_move_most_points_out_of_view():
    # a 180-degree scanner 3 m on and turned 49 deg, the odometry's increment 0.6 m and 5 deg off: the end points
    # that stay in the first scan's view wherever the 1 m / 30 deg window moves them are too few to place it
    first, second = np.array([10.8, 2.35, -1.97]), np.array([8.4, 0.54, -1.11])
    truth = np.array(relative_pose(first, second))
    drifted = truth + [-0.216, -0.552, -0.09]
    found = placed_by_a_half_circle_scanner(first, second, drifted)
    assert math.hypot(*(found[:2] - truth[:2])) < 0.05
    assert abs(wrap_angle(found[2] - truth[2])) < math.radians(1.0)


def test_a_turn_in_place_gains_nothing_by_turning_points_out_of_view():
    # a 180-degree scanner turning 120 deg on the spot: two thirds of the second scan are where the first did not look
    first = np.array([6.0, 3.0, 0.0])
    second = first + [0.0, 0.0, math.radians(120.0)]
    truth = np.array(relative_pose(first, second))
    drifted = truth + [0.05, -0.05, math.radians(8.0)]
    found = placed_by_a_half_circle_scanner(first, second, drifted)
    assert math.hypot(*(found[:2] - truth[:2])) < 0.065  # no worse than the odometry's 7 cm
    assert abs(wrap_angle(found[2] - truth[2])) < math.radians(0.5)


def test_the_posterior_mean_is_the_lattice_poses_weighted_by_their_score_and_the_odometry():
    # the compiled pass over the window's lattice (never spelled out as poses) against the module's formula over
    # window_scores' poses, in numpy: w ~ max(score, 1e-6)^N exp(-1/2 offset' Sigma^-1 offset)
    from amr_localization.scan_odometry import _Odometry, _posterior_mean
    from amr_maps.scan_matcher import CorrelativeMatcher, ScoreMap, default_angular_step
    from amr_util.geometry import one_per_cell

    first, second = (2.0, 1.0, 0.2), (2.3, 1.1, 0.3)
    reference, points = seen_from(ROOM, first), seen_from(ROOM, second)
    matcher = CorrelativeMatcher(ScoreMap.from_points(reference, 0.05, 0.05, 0.2), levels=1)
    correlated = np.array([[0.05**2, 0.0004, 0.0006], [0.0004, 0.04**2, 0.0005], [0.0006, 0.0005, 0.03**2]])
    odometry = _Odometry(np.array(relative_pose(first, second)) + [0.04, -0.03, 0.03], correlated)
    mean = _posterior_mean(matcher, points, 12.0, odometry.increment, odometry, 0.15, 0.1)
    cloud = one_per_cell(points, 0.05)
    poses, scores = matcher.window_scores(cloud, odometry.increment, 0.15, 0.1, default_angular_step(cloud, 0.05))
    log_weights = 12.0 * np.log(np.maximum(scores, 1e-6)) + odometry.log_density(poses)
    weights = np.exp(log_weights - log_weights.max())
    offsets = poses - odometry.increment
    offsets[:, 2] = wrap_angle(offsets[:, 2])
    expected = odometry.increment + weights @ offsets / weights.sum()
    np.testing.assert_allclose(mean, expected, rtol=0.0, atol=1e-12)
    assert np.abs(mean - odometry.increment).max() > 0.01  # the scans moved it
